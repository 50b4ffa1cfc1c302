//! The WGSL source of every pass: one module in ten files under `shaders/`, split by concept
//! (see `shaders/bindings.wgsl` for what each holds), joined here at compile time.

/// The shader, assembled from its files in this order (one WGSL module; `shaders/bindings.wgsl`
/// declares the bindings and the uniform `Params` every other file uses).
pub(crate) const SHADER: &str = concat!(
    include_str!("../shaders/bindings.wgsl"),
    include_str!("../shaders/arithmetic.wgsl"),
    include_str!("../shaders/lens.wgsl"),
    include_str!("../shaders/planar.wgsl"),
    include_str!("../shaders/coded.wgsl"),
    include_str!("../shaders/coverage.wgsl"),
    include_str!("../shaders/s_path.wgsl"),
    include_str!("../shaders/entries.wgsl"),
    include_str!("../shaders/objects.wgsl"),
    include_str!("../shaders/background.wgsl"),
);
