//! The service's cycle count and clock as the demo reads them between its phases (each phase
//! brings a new simulated controller up on the same FRI port).

use std::time::Duration;

use anyhow::bail;
use fri_api::client::Client;
use fri_api::protocol::Command;
use fri_api::results::StatusResult;

/// `status`, typed.
pub(super) async fn status(client: &mut Client) -> anyhow::Result<StatusResult> {
    client
        .call_typed::<StatusResult>(Command::Status, |_| {})
        .await?
        .map_err(|e| anyhow::anyhow!("status failed: {}", e.message))
}

/// Waits until the service's cycle count passes `after_cycle + margin` (a controller heard).
pub(super) async fn wait_fresh_state(
    client: &mut Client,
    after_cycle: Option<u64>,
    margin: u64,
) -> anyhow::Result<()> {
    for _ in 0..1000 {
        if let Some(c) = status(client).await?.cycle
            && after_cycle.is_none_or(|a| c > a + margin)
        {
            return Ok(());
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    bail!("the service did not see the simulated controller")
}

/// The service's newest cycle (`None` before the first measurement).
pub(super) async fn current_cycle(client: &mut Client) -> anyhow::Result<Option<u64>> {
    Ok(status(client).await?.cycle)
}

/// The service's cycle count and clock (s) at its newest measurement, read once they stopped
/// changing: the previous controller's datagrams are all processed.
pub(super) async fn service_clock(client: &mut Client) -> anyhow::Result<(u64, f64)> {
    let mut last = None;
    for _ in 0..100 {
        let s = status(client).await?;
        let now = s.cycle.zip(s.time_s);
        if let Some(settled) = now
            && last == now
        {
            return Ok(settled);
        }
        last = now;
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    bail!("the service's clock did not settle after the previous controller ended")
}
