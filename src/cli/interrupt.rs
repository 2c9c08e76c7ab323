//! Ctrl-C on an attached command (`move`, `run`, `cycle run --follow`): the first SIGINT stops
//! what the command started (a robot stop, a cycle stopped now) and exits 130; with `--detach`
//! it leaves it running and exits 0. The handler is in place before the command asks for
//! anything, so no Ctrl-C falls between the order and the watch.

use std::future::Future;

use anyhow::anyhow;
use tokio::signal::unix::{Signal, SignalKind, signal};

use super::{EXIT_OK, Failure};

/// SIGINT, caught from now on.
pub(super) struct Interrupt {
    signal: Signal,
    detach: bool,
}

impl Interrupt {
    /// Catches SIGINT from now on (call it inside the command's runtime, before its order).
    pub(super) fn catch(detach: bool) -> Result<Self, Failure> {
        let signal = signal(SignalKind::interrupt())
            .map_err(|e| Failure::Runtime(anyhow!("cannot catch Ctrl-C: {e}")))?;
        Ok(Self { signal, detach })
    }

    /// Runs `work` to its end, unless Ctrl-C comes first: then, unless detached, `stop` stops
    /// what the command started and says what it did; the command ends with exit 130 (0 when
    /// detached, saying what goes on: `running`).
    pub(super) async fn attached<T>(
        &mut self,
        work: impl Future<Output = Result<T, Failure>>,
        running: &str,
        stop: impl AsyncFnOnce() -> Result<String, Failure>,
    ) -> Result<T, Failure> {
        tokio::select! {
            done = work => done,
            _ = self.signal.recv() => {
                if self.detach {
                    eprintln!("detached: {running}");
                    return Err(Failure::Quiet(EXIT_OK));
                }
                let stopped = stop().await?;
                Err(Failure::Interrupted(anyhow!("interrupted (Ctrl-C): {stopped}")))
            }
        }
    }
}
