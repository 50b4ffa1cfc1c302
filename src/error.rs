//! The crate-level error over every subsystem's error (each keeps its `source()` chain:
//! `#[error(transparent)]` forwards both the message and the source).

/// Any synthcam error.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Splines (the S-path's curve).
    #[error(transparent)]
    Spline(#[from] crate::math::spline::SplineError),
    /// Camera model.
    #[error(transparent)]
    Camera(#[from] crate::camera::CameraError),
    /// Target definition.
    #[error(transparent)]
    Target(#[from] crate::target::TargetError),
    /// The S-path's geometry.
    #[error(transparent)]
    SPath(#[from] crate::target::s_path::SPathError),
    /// Robot models and URDF.
    #[error(transparent)]
    Robot(#[from] crate::robot::RobotError),
    /// Scene file or validation.
    #[error(transparent)]
    Scene(#[from] crate::scene::SceneError),
    /// Detector.
    #[error(transparent)]
    Detect(#[from] crate::detect::DetectError),
    /// Calibration.
    #[error(transparent)]
    Calib(#[from] crate::calib::CalibError),
    /// PnP.
    #[error(transparent)]
    Pnp(#[from] crate::pnp::PnpError),
    /// Hand-eye solvers.
    #[error(transparent)]
    HandEye(#[from] crate::handeye::HandEyeError),
    /// Renderer.
    #[cfg(feature = "render")]
    #[error(transparent)]
    Render(#[from] crate::render::RenderError),
    /// The step API, sensors and controllers.
    #[cfg(feature = "render")]
    #[error(transparent)]
    Sim(#[from] crate::sim::SimError),
    /// Observing the S-path (render, detect, PnP).
    #[cfg(feature = "render")]
    #[error(transparent)]
    Observe(#[from] crate::sim::observe::ObserveError),
    /// The course's hand-eye experiment.
    #[cfg(feature = "render")]
    #[error(transparent)]
    HandEyeRun(#[from] crate::course::handeye_run::HandEyeRunError),
    /// The course's servo loop.
    #[cfg(feature = "render")]
    #[error(transparent)]
    ServoRun(#[from] crate::course::servo_run::ServoRunError),
    /// Dataset specs.
    #[cfg(feature = "render")]
    #[error(transparent)]
    Spec(#[from] crate::dataset::SpecError),
    /// Files.
    #[cfg(feature = "render")]
    #[error(transparent)]
    Dataset(#[from] crate::dataset::DatasetError),
    /// Reports (plots, tables).
    #[cfg(feature = "render")]
    #[error(transparent)]
    Report(#[from] crate::report::ReportError),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn subsystem_errors_convert_and_keep_their_message() {
        let e: Error = crate::robot::RobotError::NonFinite { joint: 2 }.into();
        assert_eq!(e.to_string(), "joint 2 is not finite");
        let e: Error = crate::pnp::PnpError::TooFewPoints { required: 4, actual: 1 }.into();
        assert!(matches!(e, Error::Pnp(_)));
    }
}
