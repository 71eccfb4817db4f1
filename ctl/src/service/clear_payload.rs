//! `fri-ctl clear-payload`: the collision observer compensates no payload.

use std::io::{self, Write};

use clap::Args;

use fri_api::protocol::Command;
use fri_api::results::PayloadResult;

use super::JsonFlag;
use super::runner::Operation;

/// Long help of `clear-payload`.
pub(super) const HELP: &str = "\
Remove the applied payload from the collision observer and persist that (the arm does not \
move). Do this when the payload is taken off: a payload still applied without the load makes \
the residual read the missing gravity torque as a contact.";

/// `fri-ctl clear-payload`.
#[derive(Debug, Clone, Args)]
pub struct ClearPayloadArgs {
    /// Output format.
    #[command(flatten)]
    pub output: JsonFlag,
}

impl Operation for ClearPayloadArgs {
    type Output = PayloadResult;

    fn request(&self) -> Result<Command, String> {
        Ok(Command::ClearPayload)
    }

    fn json(&self) -> bool {
        self.output.json
    }

    fn print(&self, r: &PayloadResult, out: &mut dyn Write) -> io::Result<()> {
        super::apply_payload::print(r, out)
    }
}
