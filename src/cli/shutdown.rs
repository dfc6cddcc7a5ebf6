//! Graceful shutdown: a cancellation token cancelled by Ctrl-C or SIGTERM.

use tokio::signal::unix::{signal, SignalKind};
use tokio_util::sync::CancellationToken;

/// Returns a token cancelled on the first SIGINT or SIGTERM.
pub fn on_signals() -> anyhow::Result<CancellationToken> {
    let token = CancellationToken::new();
    let mut term = signal(SignalKind::terminate())?;
    let mut int = signal(SignalKind::interrupt())?;
    let t = token.clone();
    tokio::spawn(async move {
        tokio::select! {
            _ = term.recv() => {},
            _ = int.recv() => {},
        }
        t.cancel();
    });
    Ok(token)
}

/// Cancels `token` after `duration` seconds (a command's `--duration`), if given.
pub fn cancel_after(token: &CancellationToken, duration: Option<f64>) -> anyhow::Result<()> {
    let Some(d) = duration else { return Ok(()) };
    anyhow::ensure!(d.is_finite() && d > 0.0, "--duration: must be a positive number of seconds");
    let t = token.clone();
    tokio::spawn(async move {
        tokio::time::sleep(std::time::Duration::from_secs_f64(d)).await;
        t.cancel();
    });
    Ok(())
}
