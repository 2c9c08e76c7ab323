//! A TCP relay between the browser and the console that can freeze: it stops forwarding in both
//! directions without closing either connection (a switch that hangs, a cable half cut), and a
//! one-page server on another origin (another port) whose script opens the console's WebSocket.

use std::net::SocketAddr;

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::watch;

/// A relay to `upstream`; freeze it with [`Relay::freeze`].
pub struct Relay {
    pub addr: SocketAddr,
    frozen: watch::Sender<bool>,
    /// When bytes from the browser last went through to the console.
    last_up: std::sync::Arc<std::sync::Mutex<Option<std::time::Instant>>>,
}

impl Relay {
    pub async fn start(upstream: SocketAddr) -> Self {
        let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
        let addr = listener.local_addr().unwrap();
        let (frozen, _) = watch::channel(false);
        let f = frozen.clone();
        let last_up = std::sync::Arc::new(std::sync::Mutex::new(None));
        let up = std::sync::Arc::clone(&last_up);
        tokio::spawn(async move {
            while let Ok((client, _)) = listener.accept().await {
                let Ok(server) = TcpStream::connect(upstream).await else {
                    continue;
                };
                let (cr, cw) = client.into_split();
                let (sr, sw) = server.into_split();
                tokio::spawn(pipe(
                    cr,
                    sw,
                    f.subscribe(),
                    Some(std::sync::Arc::clone(&up)),
                ));
                tokio::spawn(pipe(sr, cw, f.subscribe(), None));
            }
        });
        Self {
            addr,
            frozen,
            last_up,
        }
    }

    /// When bytes from the browser (its last keep-alive, once frozen) last reached the console.
    pub fn last_up(&self) -> Option<std::time::Instant> {
        *self.last_up.lock().unwrap()
    }

    /// From now on nothing passes either way; no connection is closed.
    pub fn freeze(&self) {
        self.frozen.send_replace(true);
    }
}

async fn pipe(
    mut from: tokio::net::tcp::OwnedReadHalf,
    mut to: tokio::net::tcp::OwnedWriteHalf,
    mut frozen: watch::Receiver<bool>,
    seen: Option<std::sync::Arc<std::sync::Mutex<Option<std::time::Instant>>>>,
) {
    let mut buf = vec![0_u8; 16 * 1024];
    loop {
        let n = match from.read(&mut buf).await {
            Ok(0) | Err(_) => return,
            Ok(n) => n,
        };
        // Frozen: hold what was read, for ever, with both connections open.
        if frozen.wait_for(|f| !f).await.is_err() {
            return;
        }
        if to.write_all(&buf[..n]).await.is_err() {
            return;
        }
        if let Some(seen) = &seen {
            *seen.lock().unwrap() = Some(std::time::Instant::now());
        }
    }
}

/// Serves one page on its own port (another origin than the console's) whose script opens the
/// console's WebSocket at `console` and writes how it went into `#result`.
pub async fn foreign_page(console: SocketAddr) -> SocketAddr {
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    let page = format!(
        "<!doctype html><html><body><p id=\"result\" data-test-id=\"result\">pending</p><script>
         const r = document.getElementById('result');
         const ws = new WebSocket('ws://{console}/console/ws');
         ws.onopen = () => {{ r.textContent = 'opened'; }};
         ws.onmessage = () => {{ r.textContent = 'message'; }};
         ws.onerror = () => {{ if (r.textContent === 'pending') r.textContent = 'refused'; }};
         ws.onclose = () => {{ if (r.textContent === 'pending') r.textContent = 'refused'; }};
         </script></body></html>"
    );
    tokio::spawn(async move {
        while let Ok((mut s, _)) = listener.accept().await {
            let page = page.clone();
            tokio::spawn(async move {
                let mut buf = [0_u8; 4096];
                let _ = s.read(&mut buf).await;
                let head = format!(
                    "HTTP/1.1 200 OK\r\ncontent-type: text/html\r\ncontent-length: {}\r\nconnection: close\r\n\r\n",
                    page.len()
                );
                let _ = s.write_all(head.as_bytes()).await;
                let _ = s.write_all(page.as_bytes()).await;
            });
        }
    });
    addr
}
