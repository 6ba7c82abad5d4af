//! `campath studio`: one page on the loopback interface to scrub, play and fly a shot, set its
//! keys into the keyframe file, and follow the file's saves from the user's editor.
//!
//! The server (tiny_http) answers on 127.0.0.1 only, and only requests that carry the token
//! printed with the page's address, whose `Host` is that address (DNS rebinding), and, for a
//! write, whose `Origin` is the page's (cross-site requests). The only file it writes is the
//! shot, and only when the file on disk still has the bytes the page last loaded
//! ([`edit`]): an edit from the user's editor is never written over.
//!
//! Routes, all with `?token=…` or the header `X-Campath-Token`:
//! - `GET /`: the page;
//! - `GET /api/state?since=V`: the file's state (answers once its version passes V, or after
//!   [`LONG_POLL`]);
//! - `GET /api/shot`: what the page draws of the last valid document (tracks, keys, warnings,
//!   every frame's camera, a sample of the spheres);
//! - `GET /api/view?frame=K&width=W[&full=1][&vrp=x,y,z&vpn=x,y,z&cop=u,v,n]`: a PNG of frame K
//!   at the preview size W (one sample a pixel, no motion blur), or with `full=1` at the file's
//!   own size and sampling (the bytes of `campath render`'s frame); the flown parts replace the
//!   frame's own;
//! - `POST /api/key`, `/api/undo`, `/api/redo`: edits of the file (JSON bodies, [`edit`]).

mod edit;
mod http;
mod shot;

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::Duration;

use super::args::Shot;
use super::error::{CliError, Result};
use crate::document::Document;
use crate::Error;
use shot::{fingerprint, Good};

/// How long `GET /api/state` waits for a change before answering with the state as it is.
const LONG_POLL: Duration = Duration::from_secs(10);

/// Requests served at once; past it a request gets 503 at once (a page asks for one view and
/// one state at a time).
const MAX_REQUESTS: usize = 512;

/// Where the page is served, for `studio` and `watch`.
#[derive(clap::Args)]
pub struct Serve {
    /// The port on 127.0.0.1 [default: a free one the system picks].
    #[arg(long, default_value_t = 0)]
    pub port: u16,
    /// Open the page in the default browser.
    #[arg(long)]
    pub open: bool,
}

/// The options of `campath studio`.
#[derive(clap::Args)]
pub struct StudioArgs {
    #[command(flatten)]
    pub shot: Shot,
    #[command(flatten)]
    pub serve: Serve,
    /// Show the shot and follow its saves, but never write the file.
    #[arg(long)]
    pub read_only: bool,
}

/// The file's state as the page sees it.
pub(crate) struct State {
    /// Counts every change the page should hear of: a save, an edit, an error.
    version: u64,
    /// The file's bytes as last read or written.
    bytes: Arc<Vec<u8>>,
    /// [`fingerprint`] of `bytes`: the page's proof of what it last loaded.
    sha: String,
    /// The last valid document (perhaps of earlier bytes, when `error` is set).
    good: Option<Arc<Good>>,
    /// Counts the valid documents; the page fetches `/api/shot` again when it changes.
    good_version: u64,
    /// `/api/shot`'s body for `good`, made once.
    shot_json: Arc<String>,
    /// Why the file as it is now makes no valid document.
    error: Option<String>,
    /// The last thing the page should be told (an edit refused, the file edited outside).
    notice: Option<String>,
    /// The studio's own edits, for undo and redo: each the bytes before and after.
    undo: Vec<edit::Change>,
    redo: Vec<edit::Change>,
    /// What tells the file's versions apart ([`file_stamp`]), when last read.
    stamp: Option<Vec<i128>>,
}

/// The server's shared parts.
pub(crate) struct Studio {
    /// The shot file as given on the command line.
    file: PathBuf,
    token: String,
    port: u16,
    read_only: bool,
    state: Mutex<State>,
    /// Woken at every new version.
    changed: Condvar,
    /// Held by whoever reads and writes the file (an edit, a reload), so that the two never
    /// interleave.
    writing: Mutex<()>,
    /// Requests being served.
    busy: AtomicUsize,
}

/// Serves the page until Ctrl-C.
pub fn run(a: StudioArgs, out: &mut dyn Write) -> Result<()> {
    let file = a.shot.file.clone();
    let bytes = std::fs::read(&file)
        .map_err(|e| CliError::Usage(format!("{}: cannot read the shot: {e}", file.display())))?;
    let stop = super::progress::ctrl_c_flag()?;
    let listener = std::net::TcpListener::bind(("127.0.0.1", a.serve.port)).map_err(|e| {
        CliError::Usage(format!(
            "--port {}: cannot listen on 127.0.0.1:{}: {e}; choose another port, or leave \
             --port out for a free one",
            a.serve.port, a.serve.port
        ))
    })?;
    // A picture is sent as two writes (headers, body): with Nagle's algorithm the body's last
    // segment waits for the client's delayed acknowledgement of the headers, 40 ms a picture.
    #[cfg(target_os = "linux")]
    rustix::net::sockopt::set_tcp_nodelay(&listener, true)
        .map_err(|e| Error::read("<the studio's socket>")(e.into()))?;
    let server = tiny_http::Server::from_listener(listener, None)
        .map_err(|e| CliError::Usage(format!("cannot serve on 127.0.0.1:{}: {e}", a.serve.port)))?;
    let port = server
        .server_addr()
        .to_ip()
        .map_or(a.serve.port, |addr| addr.port());
    let studio = Arc::new(Studio {
        file: file.clone(),
        token: http::new_token()?,
        port,
        read_only: a.read_only,
        state: Mutex::new(State {
            version: 0,
            bytes: Arc::new(Vec::new()),
            sha: String::new(),
            good: None,
            good_version: 0,
            shot_json: Arc::new("null".into()),
            error: None,
            notice: None,
            undo: Vec::new(),
            redo: Vec::new(),
            stamp: None,
        }),
        changed: Condvar::new(),
        writing: Mutex::new(()),
        busy: AtomicUsize::new(0),
    });
    // No stamp: the watch reads the file once more, so a save made while it was read shows.
    studio.publish(bytes, None, None);
    let address = format!("http://127.0.0.1:{port}/?token={}", studio.token);
    let mode = if a.read_only { " (read-only)" } else { "" };
    writeln!(out, "campath studio{mode}: {}", file.display()).map_err(Error::stdout)?;
    writeln!(out, "open {address}").map_err(Error::stdout)?;
    writeln!(out, "Ctrl-C stops").map_err(Error::stdout)?;
    out.flush().map_err(Error::stdout)?;
    // Held while the studio runs: the page that leads the browser to the address.
    let _redirect = if a.serve.open {
        open_browser(&address)
    } else {
        None
    };
    let watcher = Arc::clone(&studio);
    let watching = Arc::clone(&stop);
    std::thread::Builder::new()
        .name("studio-watch".into())
        .spawn(move || watcher.follow(&watching))
        .map_err(Error::write("<watch thread>"))?;

    let server = Arc::new(server);
    while !stop.load(Ordering::SeqCst) {
        let request = match server.recv_timeout(Duration::from_millis(100)) {
            Ok(Some(r)) => r,
            Ok(None) => continue,
            Err(e) => return Err(Error::read("<the studio's socket>")(e).into()),
        };
        if studio.busy.fetch_add(1, Ordering::SeqCst) >= MAX_REQUESTS {
            studio.busy.fetch_sub(1, Ordering::SeqCst);
            let _ = request.respond(http::text(503, "busy: too many requests at once"));
            continue;
        }
        let serving = Arc::clone(&studio);
        let spawned = std::thread::Builder::new()
            .name("studio-request".into())
            .spawn(move || {
                http::serve(&serving, request);
                serving.busy.fetch_sub(1, Ordering::SeqCst);
            });
        if spawned.is_err() {
            studio.busy.fetch_sub(1, Ordering::SeqCst);
        }
    }
    writeln!(out, "stopped").map_err(Error::stdout)?;
    Ok(())
}

/// Opens `address` in the user's browser, through a page in a file only the user can read that
/// leads to it (as Jupyter does): the address with its token never appears in a command line,
/// which other local users can read. A failure is said, not fatal. Returns the file, removed
/// when dropped.
fn open_browser(address: &str) -> Option<tempfile::NamedTempFile> {
    let opener = if cfg!(target_os = "macos") {
        "open"
    } else if cfg!(windows) {
        "explorer"
    } else {
        "xdg-open"
    };
    let page = format!(
        "<!doctype html><meta charset=\"utf-8\"><meta http-equiv=\"refresh\" content=\"0;url={address}\">\
         <title>campath studio</title><a href=\"{address}\">campath studio</a>\n"
    );
    // A new temporary file is readable by its owner only.
    let made = tempfile::Builder::new()
        .prefix("campath-studio-")
        .suffix(".html")
        .tempfile()
        .and_then(|mut f| {
            std::io::Write::write_all(&mut f, page.as_bytes())?;
            Ok(f)
        });
    let file = match made {
        Ok(f) => f,
        Err(e) => {
            eprintln!(
                "campath: cannot write the page that opens the studio: {e}; open the address above"
            );
            return None;
        }
    };
    let spawned = std::process::Command::new(opener)
        .arg(file.path())
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn();
    if let Err(e) = spawned {
        eprintln!("campath: cannot open a browser with {opener}: {e}; open the address above");
    }
    Some(file)
}

impl Studio {
    /// The state, locked (a thread that panicked holding it left it whole: each change is made
    /// under one lock).
    fn lock(&self) -> std::sync::MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Makes `bytes` the file's current state: a new version, with its document or its error.
    /// A document that fails keeps the last valid one on show. `notice` is what the page is
    /// told with it.
    fn publish(&self, bytes: Vec<u8>, stamp: Option<Vec<i128>>, notice: Option<String>) {
        let loaded = load(&self.file, &bytes);
        self.install(bytes, stamp, notice, loaded);
    }

    /// [`Studio::publish`] of bytes already loaded.
    fn install(
        &self,
        bytes: Vec<u8>,
        stamp: Option<Vec<i128>>,
        notice: Option<String>,
        loaded: std::result::Result<Good, String>,
    ) {
        let mut s = self.lock();
        s.version += 1;
        s.sha = fingerprint(&bytes);
        s.bytes = Arc::new(bytes);
        s.stamp = stamp;
        s.notice = notice;
        match loaded {
            Ok(good) => {
                s.shot_json = Arc::new(good.json.to_string());
                s.good = Some(Arc::new(good));
                s.good_version = s.version;
                s.error = None;
            }
            Err(e) => s.error = Some(e),
        }
        drop(s);
        self.changed.notify_all();
    }

    /// Follows the file's saves until `stop`: every 0.1 s its state, and on a change its bytes;
    /// bytes the studio already holds (its own write) change nothing.
    fn follow(&self, stop: &std::sync::atomic::AtomicBool) {
        while !stop.load(Ordering::SeqCst) {
            std::thread::sleep(Duration::from_millis(100));
            let stamp = file_stamp(&self.file);
            if stamp == self.lock().stamp {
                continue;
            }
            let _writing = self.writing.lock().unwrap_or_else(|p| p.into_inner());
            // An editor's save is often several writes: let them settle.
            std::thread::sleep(Duration::from_millis(30));
            let stamp = file_stamp(&self.file);
            let bytes = std::fs::read(&self.file).unwrap_or_default();
            let mut s = self.lock();
            if *s.bytes == bytes {
                s.stamp = stamp;
                continue;
            }
            let dropped = !s.undo.is_empty() || !s.redo.is_empty();
            s.undo.clear();
            s.redo.clear();
            drop(s);
            // A file that fails to load may be half written (emptied, then written): it must
            // stay as it is a moment before its error is shown.
            let loaded = load(&self.file, &bytes);
            if loaded.is_err() {
                std::thread::sleep(Duration::from_millis(300));
                if file_stamp(&self.file) != stamp {
                    continue;
                }
            }
            let notice = format!(
                "the file was saved outside the studio; the page shows it as saved{}",
                if dropped {
                    " (undo and redo start again from here)"
                } else {
                    ""
                }
            );
            self.install(bytes, stamp, Some(notice), loaded);
        }
    }
}

/// The document of `bytes`, or why there is none, as the page shows it.
fn load(file: &Path, bytes: &[u8]) -> std::result::Result<Good, String> {
    let text = std::str::from_utf8(bytes).map_err(|e| {
        format!(
            "{}: the file is not UTF-8 text (byte {}); save it as UTF-8",
            file.display(),
            e.valid_up_to()
        )
    })?;
    let doc = Document::from_str(file, text).map_err(|e| e.to_string())?;
    Good::new(doc).map_err(|e| e.to_string())
}

/// What tells the file's versions apart: the file its path resolves to, its size and times,
/// and the link's own when the path is a link. None while nothing is there.
fn file_stamp(file: &Path) -> Option<Vec<i128>> {
    let target = std::fs::metadata(file).ok()?;
    let link = std::fs::symlink_metadata(file).ok()?;
    Some([target, link].iter().flat_map(identity).collect())
}

#[cfg(unix)]
fn identity(m: &std::fs::Metadata) -> [i128; 7] {
    use std::os::unix::fs::MetadataExt;
    let ns = |s: i64, n: i64| i128::from(s) * 1_000_000_000 + i128::from(n);
    [
        m.dev().into(),
        m.ino().into(),
        m.len().into(),
        ns(m.mtime(), m.mtime_nsec()),
        ns(m.ctime(), m.ctime_nsec()),
        m.mode().into(),
        m.nlink().into(),
    ]
}

#[cfg(not(unix))]
fn identity(m: &std::fs::Metadata) -> [i128; 2] {
    let since = |t: std::io::Result<std::time::SystemTime>| {
        t.ok()
            .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
            .map_or(0, |d| d.as_nanos() as i128)
    };
    [m.len().into(), since(m.modified())]
}
