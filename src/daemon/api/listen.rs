//! Serving the API's router on a listener (the Unix socket, a TCP port): hyper's HTTP/1 with a
//! header read timeout, so a connection that never sends a complete request head (a client
//! that hangs, or a thousand half-open connections) is closed after [`HEADER_READ_TIMEOUT`]
//! instead of held for ever. The same timeout closes a keep-alive connection idle that long
//! between requests; a response being streamed (a move's events) is not cut by it.
//!
//! ```text
//!  accept -> a task per connection: read the head within the timeout, else closed
//!  until completes -> stop accepting; each connection ends after its response in flight
//! ```

use std::future::Future;
use std::time::Duration;

use axum::Router;
use axum::serve::Listener;
use hyper::server::conn::http1;
use hyper_util::rt::{TokioIo, TokioTimer};
use hyper_util::service::TowerToHyperService;
use tokio::sync::watch;

use super::Caller;

/// How long a connection may take to send a complete request head (from its first byte, or
/// from the end of the response before), before it is closed.
pub const HEADER_READ_TIMEOUT: Duration = Duration::from_secs(10);

/// Who is at the other end of a connection, put on each of its requests as a [`Caller`] (the
/// journal names who sent a command).
pub trait PeerCaller {
    /// The caller.
    fn caller(&self) -> Caller;
}

impl PeerCaller for tokio::net::UnixStream {
    /// The peer's user id (`SO_PEERCRED`), when the system tells it.
    fn caller(&self) -> Caller {
        Caller::Unix {
            uid: self.peer_cred().ok().map(|c| c.uid()),
        }
    }
}

impl PeerCaller for tokio::net::TcpStream {
    fn caller(&self) -> Caller {
        match self.peer_addr() {
            Ok(address) => Caller::Tcp(address),
            Err(_) => Caller::Unix { uid: None },
        }
    }
}

/// Serves `router` on `listener` until `until` completes, then waits for the connections open
/// to end (each after the response it is sending).
pub async fn serve<L: Listener>(listener: L, router: Router, until: impl Future<Output = ()>)
where
    L::Io: PeerCaller,
{
    serve_with(listener, router, HEADER_READ_TIMEOUT, until).await;
}

/// [`serve`] with a header read timeout of `header_timeout`.
pub async fn serve_with<L: Listener>(
    mut listener: L,
    router: Router,
    header_timeout: Duration,
    until: impl Future<Output = ()>,
) where
    L::Io: PeerCaller,
{
    // Changed to tell the connections to end; each holds a receiver until it has.
    let (closing, _) = watch::channel(());
    tokio::pin!(until);
    loop {
        tokio::select! {
            (io, _) = listener.accept() => {
                let connection = connection(io, router.clone(), header_timeout);
                tokio::spawn(until_closed(connection, closing.subscribe()));
            }
            () = &mut until => break,
        }
    }
    closing.send_replace(());
    closing.closed().await;
}

/// One connection's HTTP/1 server, with the header read timeout.
fn connection<I>(
    io: I,
    router: Router,
    header_timeout: Duration,
) -> http1::Connection<TokioIo<I>, TowerToHyperService<Router>>
where
    I: tokio::io::AsyncRead + tokio::io::AsyncWrite + Unpin + Send + PeerCaller + 'static,
{
    let router = router.layer(axum::Extension(io.caller()));
    http1::Builder::new()
        .timer(TokioTimer::new())
        .header_read_timeout(header_timeout)
        .serve_connection(TokioIo::new(io), TowerToHyperService::new(router))
}

/// Runs `connection` to its end; when `closing` says so, lets it finish the response in flight
/// and end.
async fn until_closed<I>(
    connection: http1::Connection<TokioIo<I>, TowerToHyperService<Router>>,
    mut closing: watch::Receiver<()>,
) where
    I: tokio::io::AsyncRead + tokio::io::AsyncWrite + Unpin + Send + 'static,
{
    tokio::pin!(connection);
    let mut told = false;
    loop {
        tokio::select! {
            result = connection.as_mut() => {
                if let Err(e) = result {
                    tracing::debug!(error = %e, "API connection ended");
                }
                return;
            }
            _ = closing.changed(), if !told => {
                told = true;
                connection.as_mut().graceful_shutdown();
            }
        }
    }
}
