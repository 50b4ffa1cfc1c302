//! The crate-level error, collecting the subsystem errors.

/// Any synthcam error.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Calibration.
    #[error(transparent)]
    Calib(#[from] crate::calib::CalibError),
    /// Camera model.
    #[error(transparent)]
    Camera(#[from] crate::camera::CameraError),
    /// Target definition.
    #[error(transparent)]
    Target(#[from] crate::target::TargetError),
    /// Scene file or validation.
    #[error(transparent)]
    Scene(#[from] crate::scene::SceneError),
    /// Renderer.
    #[error(transparent)]
    Render(#[from] crate::render::RenderError),
    /// Detector.
    #[error(transparent)]
    Detect(#[from] crate::detect::DetectError),
    /// Files.
    #[error(transparent)]
    Dataset(#[from] crate::dataset::DatasetError),
}
