//! One writer per shard folder: a lock file created exclusively (`O_EXCL`), holding the owner's
//! pid and host, renewed while the run lives and removed when it ends.
//!
//! A lock whose owner is gone (a run killed by `kill -9`, a node that rebooted) must not block the
//! next night's run for ever. On the same host, a lock whose pid no longer exists (`/proc/<pid>`
//! is absent) is stale at once. A lock from another host (a shared file system under a job
//! array) cannot be checked through `/proc`, so every holder renews its lock: a thread touches
//! the file's modification time every [`HEARTBEAT`], and a lock not renewed for [`STALE_AFTER`]
//! (twenty heartbeats: a run that is alive but starved of I/O for that long is not mistaken for a
//! dead one) is stale whatever its host. Its age is measured against the modification time of a
//! probe file written beside it, not against this machine's clock: on a network file system both
//! times come from the same server, so clock skew between the nodes does not matter.
//! [`Lock::took_over`] says whose lock was replaced and why, for the caller to note.

use std::fs::OpenOptions;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime};

/// How often a holder renews its lock.
pub const HEARTBEAT: Duration = Duration::from_secs(30);
/// A lock not renewed for this long is stale on any host.
pub const STALE_AFTER: Duration = Duration::from_secs(600);

/// Why a lock could not be taken.
#[derive(Debug, thiserror::Error)]
pub enum LockError {
    #[error(
        "{} is in use by another run (pid {pid} on {host}, lock file {}); wait for it to finish, \
         or delete the lock file if that run is dead (a lock nobody renews for 10 minutes is \
         taken over)",
        .path.parent().map_or_else(String::new, |p| p.display().to_string()),
        .path.display()
    )]
    Held {
        path: PathBuf,
        pid: u32,
        host: String,
    },
    #[error("cannot create the lock file {}: {message}", .path.display())]
    Io { path: PathBuf, message: String },
}

/// A lock this one replaced.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TakenOver {
    pub pid: u32,
    pub host: String,
    /// Why it was stale ("no such process", "not renewed for 725 s").
    pub why: String,
}

/// A held lock, renewed by a thread while held; removed on drop.
#[derive(Debug)]
pub struct Lock {
    path: PathBuf,
    /// The owner whose stale lock this one replaced.
    pub took_over: Option<TakenOver>,
    /// Dropping the sender stops the renewing thread.
    stop: Option<mpsc::Sender<()>>,
    renewer: Option<JoinHandle<()>>,
}

/// This machine's host name (Linux: the kernel's; elsewhere `HOSTNAME` or `unknown`).
pub fn host_name() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .or_else(|| std::env::var("HOSTNAME").ok())
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "unknown".into())
}

/// Whether a process `pid` runs on this machine; `None` where that cannot be told.
fn alive(pid: u32) -> Option<bool> {
    let proc_dir = Path::new("/proc");
    if !proc_dir.join("self").exists() {
        return None;
    }
    Some(proc_dir.join(pid.to_string()).exists())
}

/// Seconds since `path` was last modified, by the clock of the file system that holds it (the
/// modification time of a probe file written beside it now); `None` where that cannot be told.
fn age_on_its_file_system(path: &Path) -> Option<f64> {
    let modified = std::fs::metadata(path).ok()?.modified().ok()?;
    let dir = path.parent()?;
    let probe = dir.join(format!(
        ".lock-probe-{}-{}",
        host_name(),
        std::process::id()
    ));
    let now = std::fs::write(&probe, b"")
        .and_then(|_| std::fs::metadata(&probe))
        .and_then(|m| m.modified())
        .unwrap_or_else(|_| SystemTime::now());
    let _ = std::fs::remove_file(&probe);
    Some(
        now.duration_since(modified)
            .map_or(0.0, |d| d.as_secs_f64()),
    )
}

/// Why the lock at `path` held by `pid` on `host` is stale, or `None` while it may be live.
fn staleness(path: &Path, pid: u32, host: &str, stale_after: Duration) -> Option<String> {
    if pid != 0 && host == host_name() && alive(pid) == Some(false) {
        return Some("no such process".into());
    }
    let age = age_on_its_file_system(path)?;
    (age > stale_after.as_secs_f64()).then(|| format!("not renewed for {age:.0} s"))
}

/// Renews the lock at `path` every `every` until `stop` is dropped.
fn renew(path: PathBuf, every: Duration, stop: mpsc::Receiver<()>) {
    loop {
        match stop.recv_timeout(every) {
            Err(RecvTimeoutError::Timeout) => {
                if let Ok(f) = OpenOptions::new().write(true).open(&path) {
                    let _ = f.set_modified(SystemTime::now());
                }
            }
            _ => return,
        }
    }
}

fn parse(text: &str) -> Option<(u32, String)> {
    let mut pid = None;
    let mut host = None;
    for line in text.lines() {
        if let Some(v) = line.strip_prefix("pid=") {
            pid = v.trim().parse().ok();
        } else if let Some(v) = line.strip_prefix("host=") {
            host = Some(v.trim().to_string());
        }
    }
    Some((pid?, host?))
}

impl Lock {
    /// Takes the lock at `path` or fails at once if a live run holds it.
    pub fn acquire(path: &Path) -> Result<Lock, LockError> {
        Lock::acquire_timed(path, HEARTBEAT, STALE_AFTER)
    }

    /// [`Lock::acquire`] with the renewal period and the staleness limit given.
    pub fn acquire_timed(
        path: &Path,
        heartbeat: Duration,
        stale_after: Duration,
    ) -> Result<Lock, LockError> {
        let mut took_over: Option<TakenOver> = None;
        for _ in 0..2 {
            match OpenOptions::new().write(true).create_new(true).open(path) {
                Ok(mut f) => {
                    let text = format!(
                        "pid={}\nhost={}\nstarted_unix_s={}\n",
                        std::process::id(),
                        host_name(),
                        std::time::SystemTime::now()
                            .duration_since(std::time::UNIX_EPOCH)
                            .map_or(0, |d| d.as_secs())
                    );
                    f.write_all(text.as_bytes())
                        .and_then(|_| f.sync_all())
                        .map_err(|e| LockError::Io {
                            path: path.to_path_buf(),
                            message: e.to_string(),
                        })?;
                    let (stop, stopped) = mpsc::channel();
                    let renewed = path.to_path_buf();
                    let renewer = std::thread::Builder::new()
                        .name("lock-renewal".into())
                        .spawn(move || renew(renewed, heartbeat, stopped))
                        .ok();
                    return Ok(Lock {
                        path: path.to_path_buf(),
                        took_over,
                        stop: Some(stop),
                        renewer,
                    });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    let text = std::fs::read_to_string(path).unwrap_or_default();
                    // A lock being written this instant reads empty: respect it.
                    let (pid, host) = parse(&text).unwrap_or((0, "unknown".into()));
                    let Some(why) = staleness(path, pid, &host, stale_after) else {
                        return Err(LockError::Held {
                            path: path.to_path_buf(),
                            pid,
                            host,
                        });
                    };
                    // Two runs may find the same stale lock; only one removes it and wins the
                    // create_new that follows.
                    let _ = std::fs::remove_file(path);
                    took_over = Some(TakenOver { pid, host, why });
                }
                Err(e) => {
                    return Err(LockError::Io {
                        path: path.to_path_buf(),
                        message: e.to_string(),
                    })
                }
            }
        }
        let t = took_over.unwrap_or(TakenOver {
            pid: 0,
            host: "unknown".into(),
            why: String::new(),
        });
        Err(LockError::Held {
            path: path.to_path_buf(),
            pid: t.pid,
            host: t.host,
        })
    }

    /// Takes the lock at `path`, waiting up to `patience` for a live holder to let go.
    pub fn wait(path: &Path, patience: Duration) -> Result<Lock, LockError> {
        let start = Instant::now();
        loop {
            match Lock::acquire(path) {
                Err(LockError::Held { .. }) if start.elapsed() < patience => {
                    std::thread::sleep(Duration::from_millis(200));
                }
                other => return other,
            }
        }
    }

    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for Lock {
    fn drop(&mut self) {
        drop(self.stop.take());
        if let Some(t) = self.renewer.take() {
            let _ = t.join();
        }
        let _ = std::fs::remove_file(&self.path);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_live_lock_refuses_and_a_dead_one_is_taken_over() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join(".lock");
        let held = Lock::acquire(&p).unwrap();
        assert!(held.took_over.is_none());
        let err = Lock::acquire(&p).unwrap_err();
        assert!(
            err.to_string().contains(&std::process::id().to_string()),
            "{err}"
        );
        drop(held);
        assert!(!p.exists());
        if alive(1) != Some(true) {
            return; // no /proc: staleness cannot be told here
        }
        // A pid that has exited.
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let dead = child.id();
        child.wait().unwrap();
        std::fs::write(&p, format!("pid={dead}\nhost={}\n", host_name())).unwrap();
        let l = Lock::acquire(&p).unwrap();
        let t = l.took_over.clone().unwrap();
        assert_eq!(
            (t.pid, t.host.as_str(), t.why.as_str()),
            (dead, host_name().as_str(), "no such process")
        );
        // Another host's lock is judged by its renewals alone: a fresh one holds.
        drop(l);
        std::fs::write(&p, format!("pid={dead}\nhost=elsewhere-{}\n", host_name())).unwrap();
        assert!(Lock::acquire(&p).is_err());
    }

    /// A holder renews its lock; another host's lock that nobody renews goes stale after the
    /// limit, one that is renewed does not.
    #[test]
    fn another_hosts_lock_is_stale_once_it_is_no_longer_renewed() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join(".lock");
        let beat = Duration::from_millis(100);
        let limit = Duration::from_millis(1500);
        let held = Lock::acquire_timed(&p, beat, limit).unwrap();
        // Backdate it: the renewal brings the time back within a heartbeat or two.
        let old = SystemTime::now() - Duration::from_secs(3600);
        OpenOptions::new()
            .write(true)
            .open(&p)
            .unwrap()
            .set_modified(old)
            .unwrap();
        std::thread::sleep(Duration::from_millis(400));
        let age = age_on_its_file_system(&p).unwrap();
        assert!(age < 1.0, "{age}");
        assert!(Lock::acquire_timed(&p, beat, limit).is_err());
        drop(held);
        assert!(!p.exists());
        // A lock of another host, renewed 2 s ago by nobody since: stale.
        std::fs::write(&p, "pid=4242\nhost=elsewhere\n").unwrap();
        let before = SystemTime::now() - Duration::from_secs(2);
        OpenOptions::new()
            .write(true)
            .open(&p)
            .unwrap()
            .set_modified(before)
            .unwrap();
        let l = Lock::acquire_timed(&p, beat, limit).unwrap();
        let t = l.took_over.clone().unwrap();
        assert_eq!((t.pid, t.host.as_str()), (4242, "elsewhere"));
        assert!(t.why.starts_with("not renewed for"), "{}", t.why);
        // The same lock 1 s old is respected.
        drop(l);
        std::fs::write(&p, "pid=4242\nhost=elsewhere\n").unwrap();
        assert!(Lock::acquire_timed(&p, beat, limit).is_err());
    }
}
