//! PostgreSQL for the tests: a throw-away cluster of their own
//! ([`Cluster`]: `initdb` as a non-root user, `pg_ctl` on a free port,
//! removed when dropped), and the backend switch of the whole service
//! suite: with `DRAPERY_TEST_PG` set (a server URL without a database, as
//! `scripts/with-postgres` sets it), every service a test starts uses a
//! PostgreSQL database of its own, named after its data directory.

use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

/// The server the whole suite runs against, when it runs on PostgreSQL.
pub fn suite_server() -> Option<String> {
    std::env::var("DRAPERY_TEST_PG")
        .ok()
        .filter(|s| !s.is_empty())
}

/// The suite runs on PostgreSQL.
pub fn on_postgres() -> bool {
    suite_server().is_some()
}

/// The flags that point a service at its store: none on SQLite (it is
/// under `--data`), else `--store` with the database of `data`, created
/// the first time.
pub fn store_flags(data: &Path) -> Vec<String> {
    match suite_server() {
        None => Vec::new(),
        Some(server) => vec!["--store".into(), database_for(&server, data)],
    }
}

/// The database of data directory `data` on `server`, created if missing.
pub fn database_for(server: &str, data: &Path) -> String {
    let name: String = data
        .file_name()
        .and_then(|n| n.to_str())
        .unwrap_or("data")
        .trim_start_matches("drapery-test-")
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_lowercase()
            } else {
                '_'
            }
        })
        .collect();
    let name = format!("t_{}", &name[name.len().saturating_sub(60)..]);
    let exists = psql(
        &format!("{server}/postgres"),
        &format!("SELECT 1 FROM pg_database WHERE datname = '{name}'"),
    );
    if exists.trim() != "1" {
        psql(
            &format!("{server}/postgres"),
            &format!("CREATE DATABASE {name}"),
        );
    }
    format!("{server}/{name}")
}

/// Runs `sql` with psql against `url`; its output, unaligned.
pub fn psql(url: &str, sql: &str) -> String {
    let out = Command::new("psql")
        .args([
            "-X",
            "-q",
            "-t",
            "-A",
            "-v",
            "ON_ERROR_STOP=1",
            url,
            "-c",
            sql,
        ])
        .output()
        .expect("psql runs");
    assert!(
        out.status.success(),
        "psql {sql:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// A PostgreSQL cluster of the test's own on a free port of 127.0.0.1,
/// with the user `postgres` trusted; stopped and removed when dropped.
pub struct Cluster {
    dir: PathBuf,
    bin: PathBuf,
    pub port: u16,
    /// Runs the server's commands as this user (when the tests are root,
    /// which PostgreSQL refuses to be).
    user: Option<&'static str>,
}

impl Cluster {
    /// Creates and starts a cluster.
    pub fn start() -> Self {
        let bin = pg_bin();
        let dir = std::env::temp_dir().join(format!("drapery-pg-{}", uuid::Uuid::now_v7()));
        std::fs::create_dir_all(&dir).expect("cluster dir");
        let user = is_root().then_some("nobody");
        if let Some(u) = user {
            run(Command::new("chown").arg(u).arg(&dir));
        }
        let port = free_port();
        let c = Self {
            dir,
            bin,
            port,
            user,
        };
        run(c
            .command("initdb")
            .args(["-U", "postgres", "-A", "trust", "--no-sync", "-D"])
            .arg(c.data()));
        c.start_server();
        c
    }

    /// `postgres://postgres@127.0.0.1:PORT` (no database).
    pub fn server(&self) -> String {
        format!("postgres://postgres@127.0.0.1:{}", self.port)
    }

    /// A new database; its URL.
    pub fn database(&self, name: &str) -> String {
        psql(
            &format!("{}/postgres", self.server()),
            &format!("CREATE DATABASE {name}"),
        );
        format!("{}/{name}", self.server())
    }

    /// Stops the server at once (`-m fast`: connections are cut).
    pub fn stop(&self) {
        run(self
            .command("pg_ctl")
            .args(["-w", "-m", "fast", "stop", "-D"])
            .arg(self.data()));
    }

    /// Starts the server again, on the same port.
    pub fn start_server(&self) {
        let opts = format!(
            "-p {} -c listen_addresses=127.0.0.1 -c unix_socket_directories='' -c fsync=off \
             -c max_connections=200",
            self.port
        );
        let log = self.dir.join("log");
        run(self
            .command("pg_ctl")
            .args(["-w", "-t", "60", "-o", &opts, "-l"])
            .arg(&log)
            .arg("start")
            .arg("-D")
            .arg(self.data()));
        let start = Instant::now();
        while std::net::TcpStream::connect(("127.0.0.1", self.port)).is_err() {
            assert!(
                start.elapsed() < Duration::from_secs(30),
                "PostgreSQL listens"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    fn data(&self) -> PathBuf {
        self.dir.join("data")
    }

    fn command(&self, program: &str) -> Command {
        let exe = self.bin.join(program);
        match self.user {
            Some(u) => {
                let mut c = Command::new("runuser");
                c.args(["-u", u, "--"]).arg(exe);
                c
            }
            None => Command::new(exe),
        }
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ = self
            .command("pg_ctl")
            .args(["-w", "-m", "immediate", "stop", "-D"])
            .arg(self.data())
            .output();
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// The directory of PostgreSQL's server programs: `PG_BIN`, or where
/// `pg_ctl` is on the PATH, or Debian's newest `/usr/lib/postgresql/*/bin`.
fn pg_bin() -> PathBuf {
    if let Ok(b) = std::env::var("PG_BIN") {
        return PathBuf::from(b);
    }
    let on_path = std::env::var_os("PATH")
        .into_iter()
        .flat_map(|p| std::env::split_paths(&p).collect::<Vec<_>>())
        .map(|d| d.join("pg_ctl"))
        .find(|p| p.exists());
    if let Some(p) = on_path {
        let real = std::fs::canonicalize(&p).unwrap_or(p);
        return real.parent().expect("a directory").to_owned();
    }
    let mut debian: Vec<PathBuf> = std::fs::read_dir("/usr/lib/postgresql")
        .into_iter()
        .flatten()
        .filter_map(Result::ok)
        .map(|e| e.path().join("bin"))
        .filter(|b| b.join("pg_ctl").exists())
        .collect();
    debian.sort();
    debian.pop().expect(
        "PostgreSQL's server programs (pg_ctl, initdb): install Debian's postgresql package, \
         or set PG_BIN",
    )
}

fn is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
}

fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .expect("a free port")
        .port()
}

fn run(c: &mut Command) -> Output {
    let out = c.output().expect("the command runs");
    assert!(
        out.status.success(),
        "{c:?}: {}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}
