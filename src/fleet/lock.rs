//! One writer per shard folder: a lock file created exclusively (`O_EXCL`), holding the owner's
//! pid and host, removed when the run ends.
//!
//! A lock whose owner is gone (a run killed by `kill -9`, a node that rebooted) must not block the
//! next night's run for ever: when the lock names this host and no process of that pid exists
//! (`/proc/<pid>` is absent), it is stale and is taken over, and [`Lock::took_over`] says from
//! whom, for the caller to note. A lock from another host (a shared file system under a job
//! array) cannot be checked from here and is always respected; the error says which file to
//! delete if that run is known to be dead. Where `/proc` does not exist (not Linux) no lock is
//! judged stale.

use std::fs::OpenOptions;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Why a lock could not be taken.
#[derive(Debug, thiserror::Error)]
pub enum LockError {
    #[error(
        "{} is in use by another run (pid {pid} on {host}, lock file {}); wait for it to finish, \
         or delete the lock file if that run is dead",
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

/// A held lock; removed on drop.
#[derive(Debug)]
pub struct Lock {
    path: PathBuf,
    /// The (pid, host) of a dead owner whose stale lock this one replaced.
    pub took_over: Option<(u32, String)>,
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
        let mut took_over = None;
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
                    return Ok(Lock {
                        path: path.to_path_buf(),
                        took_over,
                    });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    let text = std::fs::read_to_string(path).unwrap_or_default();
                    // A lock being written this instant reads empty: respect it.
                    let (pid, host) = parse(&text).unwrap_or((0, "unknown".into()));
                    let stale = pid != 0 && host == host_name() && alive(pid) == Some(false);
                    if !stale {
                        return Err(LockError::Held {
                            path: path.to_path_buf(),
                            pid,
                            host,
                        });
                    }
                    // Two runs may find the same stale lock; only one removes it and wins the
                    // create_new that follows.
                    let _ = std::fs::remove_file(path);
                    took_over = Some((pid, host));
                }
                Err(e) => {
                    return Err(LockError::Io {
                        path: path.to_path_buf(),
                        message: e.to_string(),
                    })
                }
            }
        }
        let (pid, host) = took_over.unwrap_or((0, "unknown".into()));
        Err(LockError::Held {
            path: path.to_path_buf(),
            pid,
            host,
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
        assert_eq!(l.took_over, Some((dead, host_name())));
        // Another host's lock is never judged.
        drop(l);
        std::fs::write(&p, format!("pid={dead}\nhost=elsewhere-{}\n", host_name())).unwrap();
        assert!(Lock::acquire(&p).is_err());
    }
}
