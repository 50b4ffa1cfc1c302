//! The runners' `--scenario` files: an open scenario (any camera, target, robot) or the runner's
//! own course format, told apart by parsing.

use std::path::Path;

use anyhow::Context;
use synthcam::sim::ScenarioSpec;

/// A scenario file of either format.
pub enum ScenarioFile<T> {
    /// An open scenario.
    Open(Box<ScenarioSpec>),
    /// The runner's course format (its default when no file is given).
    Course(T),
}

/// Read `path` as an open scenario, else as the course format `T` (named `format` in the error);
/// no path: `T`'s default, the course.
pub fn read<T: serde::de::DeserializeOwned + Default>(path: Option<&Path>, format: &str) -> anyhow::Result<ScenarioFile<T>> {
    let Some(p) = path else { return Ok(ScenarioFile::Course(T::default())) };
    let text = std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?;
    match ScenarioSpec::parse(&text) {
        Ok(spec) => Ok(ScenarioFile::Open(Box::new(spec))),
        Err(open) => Ok(ScenarioFile::Course(
            toml::from_str::<T>(&text).with_context(|| format!("in scenario {} (read as {format}; as an open scenario: {open})", p.display()))?,
        )),
    }
}
