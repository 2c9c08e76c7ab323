//! The console's TCP listener: a client not in `[console] allow` (loopback only without one)
//! is closed at once and logged; every other connection is served HTTP/1 with upgrades (the
//! WebSocket), its address on every request ([`super::Peer`]), and the API's header read
//! timeout.

use std::future::Future;

use axum::Router;
use hyper::server::conn::http1;
use hyper_util::rt::{TokioIo, TokioTimer};
use hyper_util::service::TowerToHyperService;
use tokio::net::TcpListener;
use tokio::sync::watch;

use super::Peer;
use crate::gateway::ClientNet;

/// Whether a client at `peer` may connect: without an allow list, a loopback client; with one,
/// a client it lists (loopback too only when listed).
#[must_use]
pub fn admits(allow: &[ClientNet], peer: std::net::IpAddr) -> bool {
    if allow.is_empty() {
        peer.to_canonical().is_loopback()
    } else {
        allow.iter().any(|net| net.contains(peer))
    }
}

/// Serves `router` on `listener` for the clients `allow` admits, until `until` completes.
pub async fn serve(
    listener: TcpListener,
    router: Router,
    allow: Vec<ClientNet>,
    until: impl Future<Output = ()>,
) {
    let (closing, _) = watch::channel(());
    tokio::pin!(until);
    loop {
        tokio::select! {
            accepted = listener.accept() => {
                let Ok((io, peer)) = accepted else { continue };
                if !admits(&allow, peer.ip()) {
                    tracing::warn!(client = %peer, "console client refused: not in console.allow");
                    continue;
                }
                let service = TowerToHyperService::new(
                    router.clone().layer(axum::Extension(Peer(peer))),
                );
                let mut told = closing.subscribe();
                tokio::spawn(async move {
                    let connection = http1::Builder::new()
                        .timer(TokioTimer::new())
                        .header_read_timeout(crate::daemon::api::HEADER_READ_TIMEOUT)
                        .serve_connection(TokioIo::new(io), service)
                        .with_upgrades();
                    tokio::pin!(connection);
                    tokio::select! {
                        result = connection.as_mut() => {
                            if let Err(e) = result {
                                tracing::debug!(error = %e, "console connection ended");
                            }
                        }
                        _ = told.changed() => {
                            connection.as_mut().graceful_shutdown();
                            let _ = connection.await;
                        }
                    }
                });
            }
            () = &mut until => break,
        }
    }
    closing.send_replace(());
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loopback_only_without_an_allow_list() {
        assert!(admits(&[], "127.0.0.1".parse().unwrap()));
        assert!(admits(&[], "::1".parse().unwrap()));
        assert!(!admits(&[], "10.0.0.5".parse().unwrap()));
        let allow = vec!["10.0.0.0/24".parse().unwrap()];
        assert!(admits(&allow, "10.0.0.5".parse().unwrap()));
        assert!(!admits(&allow, "127.0.0.1".parse().unwrap()));
    }
}
