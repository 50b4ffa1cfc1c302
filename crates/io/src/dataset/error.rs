//! The dataset spec's error (its own module: the spec, its objects and its poses all return it).

use synthcam_scene::SceneError;

/// Errors of a dataset spec.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SpecError {
    /// The text does not parse, or a field is missing, unknown or of the wrong type.
    #[error("dataset spec does not parse: {0}")]
    Parse(String),
    /// `version` is not the one this build reads ([`super::spec::SPEC_VERSION`]).
    #[error("dataset spec field `version` is {found}, this build reads version {expected}")]
    Version {
        /// The version in the file.
        found: u32,
        /// The version this build reads.
        expected: u32,
    },
    /// A field has an invalid value.
    #[error("dataset spec field `{field}` is invalid: {reason}")]
    InvalidField {
        /// Dotted path of the field, e.g. `poses.distance_m`.
        field: String,
        /// What is wrong with it.
        reason: String,
    },
    /// The camera, target or render settings are invalid.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// No sampled pose meets a constraint.
    #[error("constraint `{constraint}` is never met: 0 of {draws} sampled poses satisfy it ({hint})")]
    Infeasible {
        /// Dotted name of the constraint, e.g. `poses.full_target_visible`.
        constraint: String,
        /// Poses tried.
        draws: usize,
        /// What to change.
        hint: String,
    },
}
