//! What can go wrong setting up or using iceoryx2.

/// Errors setting up or using iceoryx2.
#[derive(Debug, thiserror::Error)]
pub enum IpcError {
    /// A name or prefix is not valid for iceoryx2.
    #[error("invalid iceoryx2 name `{name}`: {message}")]
    InvalidName {
        /// The rejected name.
        name: String,
        /// iceoryx2's reason.
        message: String,
    },
    /// Creating the node, a service or a port failed.
    #[error("iceoryx2 {what}: {message}")]
    Setup {
        /// What was being created.
        what: &'static str,
        /// iceoryx2's reason.
        message: String,
    },
    /// Sending failed (shared memory exhausted or corrupted).
    #[error("iceoryx2 send on {service}: {message}")]
    Send {
        /// Service name.
        service: &'static str,
        /// iceoryx2's reason.
        message: String,
    },
}
