//! The one error type of the models (a leaf: every module may use it, it uses none).

/// Errors a model reports to its host (the FMU shell turns them into fmi2Error / fmi2Warning).
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    /// The configuration is invalid; the message names the key and what was expected.
    #[error("invalid sensor configuration: {0}")]
    Config(String),
    /// The input of one step is unusable (the frame is skipped, the model stays usable).
    #[error("invalid input: {0}")]
    Input(String),
}

/// `Ok` where `v` is finite and in `[lo, hi]`, else the configuration error
/// ``"`{prefix}.{key}` must be in [{lo}, {hi}], got {v}"``: the range check of the
/// configurations' `validate` methods (`prefix` is the section, e.g. `camera.recognition`).
pub(crate) fn check_range(
    prefix: &str,
    key: &str,
    v: f64,
    lo: f64,
    hi: f64,
) -> Result<(), ModelError> {
    if v.is_finite() && v >= lo && v <= hi {
        Ok(())
    } else {
        Err(ModelError::Config(format!(
            "`{prefix}.{key}` must be in [{lo}, {hi}], got {v}"
        )))
    }
}
