//! Child processes of `lumen demo`: spawned with the termination signals unblocked (the parent
//! blocks them to take them in its own loop, and a blocked mask survives `exec`), their stdout
//! read line by line on a channel, stopped with a signal and reaped.

use crate::error::{CliError, CliResult};
use std::io::{BufRead, BufReader, Write};
use std::os::unix::process::CommandExt;
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

/// What [`Proc::line`] saw.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Next {
    /// A line of stdout.
    Line(String),
    /// Nothing within the timeout.
    Waiting,
    /// stdout is closed and every line has been read.
    Closed,
}

/// A running child with its stdout lines.
pub struct Proc {
    /// What it is, for messages ("daemon", "sim", "recorder").
    pub name: &'static str,
    child: Child,
    lines: Receiver<String>,
    status: Option<ExitStatus>,
}

impl Proc {
    /// Spawns `cmd` (stdout and stdin piped, stderr inherited).
    pub fn spawn(name: &'static str, mut cmd: Command) -> CliResult<Self> {
        cmd.stdout(Stdio::piped()).stderr(Stdio::inherit()).stdin(Stdio::piped());
        // SAFETY: between fork and exec only async-signal-safe calls (sigemptyset, sigaddset,
        // pthread_sigmask) on a local set.
        unsafe {
            cmd.pre_exec(|| {
                let mut set: libc::sigset_t = std::mem::zeroed();
                libc::sigemptyset(&mut set);
                libc::sigaddset(&mut set, libc::SIGINT);
                libc::sigaddset(&mut set, libc::SIGTERM);
                libc::pthread_sigmask(libc::SIG_UNBLOCK, &set, std::ptr::null_mut());
                Ok(())
            });
        }
        let mut child = cmd.spawn().map_err(|source| CliError::Spawn { name, source })?;
        let stdout = child.stdout.take().expect("piped");
        let (tx, lines) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        Ok(Self { name, child, lines, status: None })
    }

    /// The process id.
    pub fn id(&self) -> u32 {
        self.child.id()
    }

    /// The next stdout line, waiting up to `timeout`.
    pub fn line(&self, timeout: Duration) -> Next {
        match self.lines.recv_timeout(timeout) {
            Ok(l) => Next::Line(l),
            Err(RecvTimeoutError::Timeout) => Next::Waiting,
            Err(RecvTimeoutError::Disconnected) => Next::Closed,
        }
    }

    /// Writes `line` and a newline to its stdin.
    pub fn send_line(&mut self, line: &str) -> CliResult {
        let name = self.name;
        let stdin = self.child.stdin.as_mut().ok_or(CliError::StdinClosed { name })?;
        writeln!(stdin, "{line}").and_then(|()| stdin.flush()).map_err(|source| CliError::ChildStdin { name, source })
    }

    /// The exit status, if it has exited.
    pub fn exited(&mut self) -> Option<ExitStatus> {
        if self.status.is_none() {
            self.status = self.child.try_wait().ok().flatten();
        }
        self.status
    }

    /// Sends `sig` if it is still running.
    pub fn signal(&mut self, sig: i32) {
        if self.exited().is_none() {
            // SAFETY: signalling our own child, not yet reaped, by its pid.
            unsafe { libc::kill(self.child.id() as i32, sig) };
        }
    }

    /// Waits up to `limit` for the exit; then SIGKILL and reap. Returns the status.
    pub fn wait(&mut self, limit: Duration) -> Option<ExitStatus> {
        let end = Instant::now() + limit;
        while Instant::now() < end {
            if let Some(s) = self.exited() {
                return Some(s);
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        let _ = self.child.kill();
        self.status = self.child.wait().ok();
        self.status
    }

    /// Sends `sig` and waits up to `limit` (then SIGKILL).
    pub fn stop(&mut self, sig: i32, limit: Duration) -> Option<ExitStatus> {
        self.signal(sig);
        self.wait(limit)
    }
}

impl Drop for Proc {
    /// Never leaves a child behind: SIGTERM, 5 s, SIGKILL, reaped.
    fn drop(&mut self) {
        if self.exited().is_none() {
            self.stop(libc::SIGTERM, Duration::from_secs(5));
        }
    }
}
