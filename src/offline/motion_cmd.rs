//! `offline estimate-motion`: full inertial estimate from trajectory logs (paper Sec. V).

use std::io::Write;

use super::args::MotionArgs;

/// `offline estimate-motion`.
pub fn estimate_motion(a: &MotionArgs, _out: &mut dyn Write) -> anyhow::Result<()> {
    anyhow::bail!("estimate-motion for {}: not wired yet", a.log.display())
}
