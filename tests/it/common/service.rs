//! The real `preston` binary, serving on an ephemeral loopback port: its address (read from
//! its start-up log line), everything it has logged since, and signals. Killed when dropped.

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

pub struct Service {
    child: Child,
    /// Its records store, when a SQLite file of its own (removed when dropped).
    database: Option<std::path::PathBuf>,
    /// `127.0.0.1:PORT`.
    pub address: String,
    /// Standard error so far (the log).
    pub log: Arc<Mutex<String>>,
}

impl Service {
    /// `preston serve` on 127.0.0.1:0 with no drain delay, then `args`.
    pub fn start(args: &[&str]) -> Service {
        Service::start_with(
            &["serve", "--listen", "127.0.0.1:0", "--drain-delay-ms", "0"],
            args,
        )
    }

    /// `preston` with `base` then `args` (`base` must make it listen and log its address).
    pub fn start_with(base: &[&str], args: &[&str]) -> Service {
        let database = std::env::temp_dir().join(format!(
            "preston-service-{}-{}.db",
            std::process::id(),
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .unwrap()
                .as_nanos()
        ));
        let url = format!("sqlite://{}", database.display());
        let mut service = Service::spawn(base, args, &url);
        service.database = Some(database);
        service
    }

    /// `preston serve` on the records store at `url`, which outlives it.
    pub fn start_on(url: &str) -> Service {
        Service::spawn(
            &["serve", "--listen", "127.0.0.1:0", "--drain-delay-ms", "0"],
            &[],
            url,
        )
    }

    fn spawn(base: &[&str], args: &[&str], url: &str) -> Service {
        let mut child = Command::new(env!("CARGO_BIN_EXE_preston"))
            .args(base)
            .args(args)
            .env("PRESTON_DATABASE_URL", url)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let mut stderr = BufReader::new(child.stderr.take().unwrap());
        let log = Arc::new(Mutex::new(String::new()));
        let mut line = String::new();
        // The line "… address=127.0.0.1:PORT" tells where it listens.
        let address = loop {
            line.clear();
            assert!(
                stderr.read_line(&mut line).unwrap() > 0,
                "server exited early: {}",
                log.lock().unwrap()
            );
            log.lock().unwrap().push_str(&line);
            if let Some(rest) = line.split("address=").nth(1) {
                break rest.split_whitespace().next().unwrap().to_string();
            }
        };
        let sink = log.clone();
        std::thread::spawn(move || {
            for line in stderr.lines().map_while(Result::ok) {
                sink.lock().unwrap().push_str(&(line + "\n"));
            }
        });
        Service {
            child,
            database: None,
            address,
            log,
        }
    }

    /// Sends the signal named `name` (`HUP`, `TERM`, …).
    pub fn signal(&self, name: &str) {
        let status = Command::new("kill")
            .args([format!("-{name}"), self.child.id().to_string()])
            .status()
            .unwrap();
        assert!(status.success());
    }

    /// Waits for the process to exit.
    pub fn wait(&mut self) -> ExitStatus {
        self.child.wait().unwrap()
    }

    /// Waits until the log has `count` occurrences of `text`.
    pub fn wait_for_log(&self, text: &str, count: usize) {
        let started = Instant::now();
        while self.log.lock().unwrap().matches(text).count() < count {
            assert!(
                started.elapsed() < Duration::from_secs(10),
                "no {text:?} in the log:\n{}",
                self.log.lock().unwrap()
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

impl Drop for Service {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        if let Some(database) = &self.database {
            for suffix in ["", "-wal", "-shm"] {
                let _ = std::fs::remove_file(format!("{}{suffix}", database.display()));
            }
        }
    }
}
