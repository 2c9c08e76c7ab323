//! Child processes for the interop tests: killed on drop, their output collected line by line,
//! and every wait bounded by a timeout that fails with what the process printed so far.
//!
//! A reader thread per stream appends lines to a shared [`Output`] and wakes waiters through a
//! condition variable, so waiting for a line never polls.

use std::fmt::Write as _;
use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread;
use std::time::{Duration, Instant};

/// What a child printed so far, and which of its streams have closed.
#[derive(Debug, Default)]
pub struct Output {
    pub stdout: Vec<String>,
    pub stderr: Vec<String>,
    stdout_closed: bool,
    stderr_closed: bool,
}

impl Output {
    fn closed(&self) -> bool {
        self.stdout_closed && self.stderr_closed
    }
}

#[derive(Debug, Default)]
struct Shared {
    output: Mutex<Output>,
    changed: Condvar,
}

impl Shared {
    fn lock(&self) -> MutexGuard<'_, Output> {
        self.output
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }
}

#[derive(Debug, Clone, Copy)]
enum Stream {
    Stdout,
    Stderr,
}

fn collect(shared: Arc<Shared>, stream: Stream, source: impl Read + Send + 'static) {
    thread::spawn(move || {
        for line in BufReader::new(source).lines() {
            let Ok(line) = line else { break };
            let mut output = shared.lock();
            match stream {
                Stream::Stdout => output.stdout.push(line),
                Stream::Stderr => output.stderr.push(line),
            }
            shared.changed.notify_all();
        }
        let mut output = shared.lock();
        match stream {
            Stream::Stdout => output.stdout_closed = true,
            Stream::Stderr => output.stderr_closed = true,
        }
        shared.changed.notify_all();
    });
}

/// A running child process, killed (SIGKILL) and reaped when dropped.
#[derive(Debug)]
pub struct Spawned {
    name: String,
    child: Child,
    shared: Arc<Shared>,
    reaped: Option<ExitStatus>,
}

impl Spawned {
    /// Starts `command` with stdout and stderr captured (stdin closed). `name` is used in every
    /// failure message.
    pub fn spawn(name: &str, mut command: Command) -> Self {
        let described = format!("{command:?}");
        let mut child = command
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap_or_else(|e| panic!("could not start {name} ({described}): {e}"));
        let shared = Arc::new(Shared::default());
        collect(
            Arc::clone(&shared),
            Stream::Stdout,
            child.stdout.take().expect("stdout is piped"),
        );
        collect(
            Arc::clone(&shared),
            Stream::Stderr,
            child.stderr.take().expect("stderr is piped"),
        );
        Self {
            name: name.to_owned(),
            child,
            shared,
            reaped: None,
        }
    }

    /// The child's process id.
    pub fn id(&self) -> u32 {
        self.child.id()
    }

    /// Waits until `found` returns `Some` on the output so far; panics after `timeout`, or once
    /// both streams have closed without it, with everything the child printed.
    pub fn wait_for<T>(
        &mut self,
        what: &str,
        timeout: Duration,
        mut found: impl FnMut(&Output) -> Option<T>,
    ) -> T {
        let deadline = Instant::now() + timeout;
        let mut output = self.shared.lock();
        loop {
            if let Some(value) = found(&output) {
                return value;
            }
            let now = Instant::now();
            if output.closed() || now >= deadline {
                let why = if output.closed() {
                    "it closed its output first".to_owned()
                } else {
                    format!("not within {timeout:?}")
                };
                let seen = describe(&output);
                drop(output);
                let status = self.status_now();
                panic!(
                    "{}: waited for {what}, {why}; exit status: {status}\n{seen}",
                    self.name
                );
            }
            output = self
                .shared
                .changed
                .wait_timeout(output, deadline - now)
                .unwrap_or_else(std::sync::PoisonError::into_inner)
                .0;
        }
    }

    /// Waits for the child's first stdout line and returns what follows `prefix` on it; panics if
    /// the first line does not start with `prefix`.
    pub fn first_line_after(&mut self, prefix: &str, timeout: Duration) -> String {
        let what = format!("a first stdout line `{prefix}...`");
        let first = self.wait_for(&what, timeout, |out| out.stdout.first().cloned());
        if let Some(rest) = first.strip_prefix(prefix) {
            return rest.trim().to_owned();
        }
        let seen = describe(&self.shared.lock());
        panic!(
            "{}: expected the first stdout line to start with `{prefix}`, got `{first}`\n{seen}",
            self.name
        )
    }

    /// Waits until a stderr line contains `needle`.
    pub fn wait_for_stderr(&mut self, needle: &str, timeout: Duration) {
        let what = format!("a stderr line containing `{needle}`");
        self.wait_for(&what, timeout, |out| {
            out.stderr.iter().any(|l| l.contains(needle)).then_some(())
        });
    }

    /// Waits for the child to exit by itself within `timeout` (it is killed and the test fails
    /// otherwise) and returns its status with everything it printed.
    pub fn finish(mut self, timeout: Duration) -> Finished {
        self.wait_for("the process to exit", timeout, |out| {
            out.closed().then_some(())
        });
        let status = self.reap();
        let output = self.shared.lock();
        Finished {
            status,
            stdout: output.stdout.join("\n"),
            stderr: output.stderr.join("\n"),
        }
    }

    /// Sends SIGTERM and waits up to `timeout` for the child to exit; returns its status.
    pub fn terminate(&mut self, timeout: Duration) -> ExitStatus {
        self.signal("TERM");
        self.wait_for("the process to exit after SIGTERM", timeout, |out| {
            out.closed().then_some(())
        });
        self.reap()
    }

    /// Sends SIGINT, as Ctrl-C on a terminal does (the child exits by itself: `finish`).
    pub fn interrupt(&mut self) {
        self.signal("INT");
    }

    /// Sends SIGHUP, as `systemctl reload` does (the unit's `ExecReload=`).
    pub fn hangup(&self) {
        self.signal("HUP");
    }

    fn signal(&self, name: &str) {
        let pid = self.id().to_string();
        // The shell's builtin kill: no dependency on procps, no unsafe code.
        let sent = Command::new("sh")
            .args(["-c", &format!("kill -{name} \"$1\""), "sh", &pid])
            .status()
            .unwrap_or_else(|e| panic!("{}: could not run kill -{name} {pid}: {e}", self.name));
        assert!(sent.success(), "{}: kill -{name} {pid} failed", self.name);
    }

    /// Everything the child printed so far.
    pub fn output(&self) -> String {
        describe(&self.shared.lock())
    }

    fn reap(&mut self) -> ExitStatus {
        if let Some(status) = self.reaped {
            return status;
        }
        let status = self
            .child
            .wait()
            .unwrap_or_else(|e| panic!("{}: wait failed: {e}", self.name));
        self.reaped = Some(status);
        status
    }

    fn status_now(&mut self) -> String {
        match self.child.try_wait() {
            Ok(Some(status)) => {
                self.reaped = Some(status);
                status.to_string()
            }
            Ok(None) => "not exited yet".to_owned(),
            Err(e) => format!("unknown ({e})"),
        }
    }
}

impl Drop for Spawned {
    fn drop(&mut self) {
        if self.reaped.is_none() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// A process that ran to its end.
#[derive(Debug)]
pub struct Finished {
    pub status: ExitStatus,
    pub stdout: String,
    pub stderr: String,
}

impl Finished {
    /// Both streams, for a failure message.
    pub fn describe(&self) -> String {
        format!(
            "exit status: {}\n--- stdout ---\n{}\n--- stderr ---\n{}",
            self.status, self.stdout, self.stderr
        )
    }
}

fn describe(output: &Output) -> String {
    let mut text = String::from("--- stdout ---\n");
    for line in &output.stdout {
        let _ = writeln!(text, "{line}");
    }
    text.push_str("--- stderr ---\n");
    for line in &output.stderr {
        let _ = writeln!(text, "{line}");
    }
    text
}

/// A fresh directory under the system's temp dir, removed with its contents on drop.
#[derive(Debug)]
pub struct TempDir {
    path: PathBuf,
}

impl TempDir {
    pub fn new(label: &str) -> Self {
        static NEXT: AtomicUsize = AtomicUsize::new(0);
        let path = std::env::temp_dir().join(format!(
            "linterpd-{label}-{}-{}",
            std::process::id(),
            NEXT.fetch_add(1, Ordering::Relaxed)
        ));
        let _ = std::fs::remove_dir_all(&path);
        std::fs::create_dir_all(&path)
            .unwrap_or_else(|e| panic!("could not create {}: {e}", path.display()));
        Self { path }
    }

    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.path);
    }
}
