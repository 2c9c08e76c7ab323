//! Debian's chromedriver and chromium, driven over `WebDriver` by fantoccini: no driver downloads.
//! A chromedriver per test on a free port (started here, killed by its id when the test ends);
//! each browser headless with its own fresh profile directory; the console's page logged in.

use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use fantoccini::actions::{InputSource, MOUSE_BUTTON_LEFT, MouseActions, PointerAction};
use fantoccini::{Client, ClientBuilder, Locator};
use serde_json::{Value, json};

/// How long the page may take for anything in these tests.
pub const LIMIT: Duration = Duration::from_secs(20);

/// A chromedriver we started.
pub struct Driver {
    child: Child,
    pub url: String,
}

impl Driver {
    /// Starts `/usr/bin/chromedriver` (or `$LINTERPD_CHROMEDRIVER`) on a free port.
    pub async fn start() -> Self {
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port();
        let program = std::env::var("LINTERPD_CHROMEDRIVER")
            .unwrap_or_else(|_| "/usr/bin/chromedriver".to_owned());
        let child = Command::new(&program)
            .arg(format!("--port={port}"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap_or_else(|e| {
                panic!("{program}: {e} (apt-get install chromium chromium-driver; .ci/run does)")
            });
        let url = format!("http://127.0.0.1:{port}");
        // Ready when its port takes a connection.
        let deadline = tokio::time::Instant::now() + LIMIT;
        while tokio::net::TcpStream::connect(("127.0.0.1", port))
            .await
            .is_err()
        {
            assert!(
                tokio::time::Instant::now() < deadline,
                "chromedriver never listened"
            );
            tokio::task::yield_now().await;
        }
        Self { child, url }
    }

    /// A headless browser with a fresh profile.
    pub async fn browser(&self) -> Browser {
        let profile = std::env::temp_dir().join(format!(
            "linterpd-chromium-{}-{}",
            std::process::id(),
            rand_suffix()
        ));
        let mut caps = serde_json::Map::new();
        caps.insert("browserName".into(), json!("chrome"));
        caps.insert(
            "goog:chromeOptions".into(),
            json!({
                "binary": std::env::var("LINTERPD_CHROMIUM").unwrap_or_else(|_| "/usr/bin/chromium".into()),
                "args": [
                    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                    "--no-first-run", "--disable-background-networking",
                    "--disable-component-update", "--disable-sync",
                    "--window-size=1400,1100",
                    format!("--user-data-dir={}", profile.display()),
                ]
            }),
        );
        let connector = hyper_util::client::legacy::connect::HttpConnector::new();
        let client = ClientBuilder::new(connector)
            .capabilities(caps)
            .connect(&self.url)
            .await
            .expect("a chromium session");
        Browser { client, profile }
    }
}

impl Drop for Driver {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn rand_suffix() -> u64 {
    use std::sync::atomic::{AtomicU64, Ordering};
    static N: AtomicU64 = AtomicU64::new(0);
    N.fetch_add(1, Ordering::SeqCst)
}

/// One browser, its page the console.
pub struct Browser {
    pub client: Client,
    profile: PathBuf,
}

fn css(test_id: &str) -> String {
    format!("[data-test-id=\"{test_id}\"]")
}

impl Browser {
    /// Opens `url` and logs in as `user` (the demo's password); waits for the robot's phase.
    pub async fn login(&self, url: &str, user: &str) {
        self.client.goto(url).await.unwrap();
        self.find("login-user").await.send_keys(user).await.unwrap();
        self.find("login-password")
            .await
            .send_keys(&format!("{user}-demo"))
            .await
            .unwrap();
        self.find("login-submit").await.click().await.unwrap();
        self.find("phase").await;
    }

    /// The element of `data-test-id`, waiting for it.
    pub async fn find(&self, test_id: &str) -> fantoccini::elements::Element {
        let selector = css(test_id);
        tokio::time::timeout(
            LIMIT,
            self.client
                .wait()
                .forever()
                .for_element(Locator::Css(&selector)),
        )
        .await
        .unwrap_or_else(|_| panic!("no {selector} on the page"))
        .unwrap()
    }

    /// The text of `data-test-id`.
    pub async fn text(&self, test_id: &str) -> String {
        self.find(test_id).await.text().await.unwrap()
    }

    pub async fn click(&self, test_id: &str) {
        self.find(test_id).await.click().await.unwrap();
    }

    /// Whether an element of `data-test-id` is there now.
    pub async fn has(&self, test_id: &str) -> bool {
        self.client.find(Locator::Css(&css(test_id))).await.is_ok()
    }

    /// Waits (on the page's own changes: a `MutationObserver`) until `js` (an expression) is true.
    pub async fn until(&self, js: &str) {
        let script = format!(
            "const done = arguments[arguments.length - 1];
             const ok = () => {{ try {{ return !!({js}); }} catch (_) {{ return false; }} }};
             if (ok()) {{ done(true); return; }}
             const o = new MutationObserver(() => {{ if (ok()) {{ o.disconnect(); done(true); }} }});
             o.observe(document.body, {{subtree: true, childList: true, characterData: true, attributes: true}});"
        );
        let r = tokio::time::timeout(LIMIT, self.client.execute_async(&script, vec![]))
            .await
            .unwrap_or_else(|_| panic!("never: {js}"));
        assert_eq!(r.unwrap(), Value::Bool(true), "{js}");
    }

    /// The text of `data-test-id` by script (for `until` conditions).
    pub fn js_text(test_id: &str) -> String {
        format!(
            "(document.querySelector('{}') || {{}}).textContent",
            css(test_id).replace('\'', "\\'")
        )
    }

    /// Presses the pointer on `data-test-id` and keeps it down (W3C actions; released by
    /// [`Self::release`], or never).
    pub async fn press(&self, test_id: &str) {
        let element = self.find(test_id).await;
        let down = MouseActions::new("mouse".into())
            .then(PointerAction::MoveToElement {
                element,
                duration: None,
                x: 0.0,
                y: 0.0,
            })
            .then(PointerAction::Down {
                button: MOUSE_BUTTON_LEFT,
            });
        self.client.perform_actions(down).await.unwrap();
    }

    /// Releases every pointer held (the W3C "release actions": a pointerup on the page).
    pub async fn release(&self) {
        self.client.release_actions().await.unwrap();
    }

    /// Saves a screenshot to `target/console-screenshots/NAME.png`; its path.
    pub async fn screenshot(&self, name: &str) -> PathBuf {
        let png = self.client.screenshot().await.unwrap();
        let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/console-screenshots");
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(format!("{name}.png"));
        std::fs::write(&path, png).unwrap();
        path
    }

    /// The browser's main process, by its profile directory (ours alone), killed at once: as a
    /// crash or a pulled plug would end it.
    pub fn kill(&self) {
        let marker = format!("--user-data-dir={}", self.profile.display());
        for entry in std::fs::read_dir("/proc").unwrap().flatten() {
            let Ok(pid) = entry.file_name().to_string_lossy().parse::<i32>() else {
                continue;
            };
            let Ok(cmdline) = std::fs::read(entry.path().join("cmdline")) else {
                continue;
            };
            let args: Vec<String> = cmdline
                .split(|b| *b == 0)
                .map(|a| String::from_utf8_lossy(a).into_owned())
                .collect();
            let main = args.contains(&marker) && !args.iter().any(|a| a.starts_with("--type="));
            if main {
                let _ = Command::new("kill")
                    .arg("-KILL")
                    .arg(pid.to_string())
                    .status();
            }
        }
    }

    pub async fn close(self) {
        let _ = self.client.close().await;
        let _ = std::fs::remove_dir_all(&self.profile);
    }
}
