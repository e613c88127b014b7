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
