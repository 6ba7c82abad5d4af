//! `campath studio`: the door (token, Host, Origin, bad and stuck requests), the edits of the
//! file (one track's keys, undo to the same bytes, an editor's save never written over), and the
//! page in headless Chromium (`studio.mjs`): its pixels against `campath render`'s, a flown key,
//! undo, a refused edit, and `check`'s warnings on the timeline. Nothing here is timed: each
//! wait is for an answer, with a limit only so that a studio that never answers fails.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::common::{campath, does_not_run, need_part, root, stdout};

/// A shot with comments, a multi-line Observer track and a Track track.
const FILE: &str = "// A shot the studio edits.
(
    frames: 24, fps: 12.0,
    image: (width: 64, height: 36, samples: 2),
    camera: (vrp: (0.0, 1.0, -6.0), vuv: (0.0, 1.0, 0.0), window: (1.6, 0.9)),
    animate: [
        // The eye's path.
        Observer(keys: [
            (t: 0.0, value: (0.0, 1.0, -6.0)), // start
            (t: 1.5, value: (2.0, 1.5, -5.0)),
        ], interpolation: CatmullRom),
        Track(keys: [(t: 0.0, value: (0.0, 0.0, 0.0))]),
    ],
    scene: (lights: [(direction: (-1.0, -2.0, 1.0))],
            spheres: [(center: (0.0, 0.0, 0.0), radius: 1.0, color: (0.9, 0.2, 0.2)),
                      (center: (1.5, 0.0, 1.0), radius: 0.5)]),
)
";

/// How long a wait for the studio goes on before the test fails.
const PATIENCE: Duration = Duration::from_secs(120);

/// A running `campath studio`, stopped when dropped.
struct Studio {
    child: Child,
    port: u16,
    token: String,
    url: String,
}

impl Drop for Studio {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn start(dir: &Path, file: &str, extra: &[&str]) -> Studio {
    let mut child = Command::new(env!("CARGO_BIN_EXE_campath"))
        .current_dir(dir)
        .arg("studio")
        .arg(file)
        .args(extra)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
    let url = lines
        .find_map(|l| l.ok()?.strip_prefix("open ").map(str::to_string))
        .expect("the studio prints its address");
    // Its later lines are not read: keep the pipe drained.
    std::thread::spawn(move || lines.for_each(drop));
    let rest = url.strip_prefix("http://127.0.0.1:").unwrap();
    let (port, token) = rest.split_once("/?token=").unwrap();
    assert_eq!(token.len(), 64, "{url}");
    Studio {
        child,
        port: port.parse().unwrap(),
        token: token.to_string(),
        url,
    }
}

/// The status and body of a raw HTTP/1.1 request (the connection closed after it).
fn raw(port: u16, request: &str) -> (u16, String) {
    let mut s = TcpStream::connect(("127.0.0.1", port)).unwrap();
    s.set_read_timeout(Some(PATIENCE)).unwrap();
    s.write_all(request.as_bytes()).unwrap();
    let mut answer = Vec::new();
    s.read_to_end(&mut answer).unwrap();
    let text = String::from_utf8_lossy(&answer).into_owned();
    let status = text
        .split(' ')
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or_else(|| panic!("no status in {text:?}"));
    let body = text
        .split_once("\r\n\r\n")
        .map_or("", |(_, b)| b)
        .to_string();
    (status, body)
}

impl Studio {
    fn host(&self) -> String {
        format!("127.0.0.1:{}", self.port)
    }

    fn get(&self, path: &str) -> (u16, String) {
        let sep = if path.contains('?') { '&' } else { '?' };
        raw(
            self.port,
            &format!(
                "GET {path}{sep}token={} HTTP/1.1\r\nHost: {}\r\nConnection: close\r\n\r\n",
                self.token,
                self.host()
            ),
        )
    }

    fn post(&self, path: &str, body: &str) -> (u16, String) {
        let origin = format!("http://{}", self.host());
        self.post_from(path, body, Some(&origin))
    }

    fn post_from(&self, path: &str, body: &str, origin: Option<&str>) -> (u16, String) {
        let origin = origin.map_or(String::new(), |o| format!("Origin: {o}\r\n"));
        raw(
            self.port,
            &format!(
                "POST {path} HTTP/1.1\r\nHost: {}\r\nX-Campath-Token: {}\r\n{origin}Content-Type: \
                 application/json\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{body}",
                self.host(),
                self.token,
                body.len()
            ),
        )
    }

    /// The state once `want` holds for it.
    fn state_where(&self, want: impl Fn(&serde_json::Value) -> bool) -> serde_json::Value {
        let started = Instant::now();
        loop {
            let (status, body) = self.get("/api/state");
            assert_eq!(status, 200, "{body}");
            let v: serde_json::Value = serde_json::from_str(&body).unwrap();
            if want(&v) {
                return v;
            }
            assert!(started.elapsed() < PATIENCE, "no such state: {v}");
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    fn sha(&self) -> String {
        self.state_where(|_| true)["sha"]
            .as_str()
            .unwrap()
            .to_string()
    }
}

fn shot(dir: &Path) -> PathBuf {
    let file = dir.join("s.ron");
    std::fs::write(&file, FILE).unwrap();
    file
}

/// The text between the `keys: [` of `track` and its closing bracket, found by a plain search
/// of this test's own (the file's keys hold no brackets in comments).
fn keys_span(text: &str, track: &str) -> (usize, usize) {
    let start = text.find(&format!("{track}(keys: [")).unwrap() + track.len() + 8;
    let mut depth = 1;
    for (i, c) in text[start..].char_indices() {
        match c {
            '[' => depth += 1,
            ']' => {
                depth -= 1;
                if depth == 0 {
                    return (start, start + i);
                }
            }
            _ => {}
        }
    }
    panic!("no end of {track}'s keys");
}

#[test]
fn the_door_answers_only_the_token_on_the_studios_own_address_and_origin() {
    let tmp = tempfile::tempdir().unwrap();
    let file = shot(tmp.path());
    let s = start(tmp.path(), "s.ron", &[]);
    let host = s.host();
    let ask = |path: &str, headers: &str| {
        raw(
            s.port,
            &format!("GET {path} HTTP/1.1\r\n{headers}Connection: close\r\n\r\n"),
        )
        .0
    };
    let wrong = "0".repeat(64);
    for path in ["/", "/api/state", "/api/shot", "/api/view?frame=0"] {
        assert_eq!(
            ask(path, &format!("Host: {host}\r\n")),
            403,
            "{path} without the token"
        );
        let sep = if path.contains('?') { '&' } else { '?' };
        let with = |t: &str| format!("{path}{sep}token={t}");
        assert_eq!(
            ask(&with(&wrong), &format!("Host: {host}\r\n")),
            403,
            "{path}, wrong token"
        );
        assert_eq!(
            ask(&with(&s.token[..63]), &format!("Host: {host}\r\n")),
            403
        );
        assert_eq!(
            ask(&with(&s.token), &format!("Host: {host}\r\n")),
            200,
            "{path}"
        );
        assert_eq!(
            ask(&with(&s.token), &format!("Host: localhost:{}\r\n", s.port)),
            200
        );
        // DNS rebinding: another name that resolves here is not the studio's address.
        assert_eq!(
            ask(&with(&s.token), "Host: evil.example\r\n"),
            403,
            "{path}"
        );
        assert_eq!(
            ask(
                &with(&s.token),
                &format!("Host: evil.example:{}\r\n", s.port)
            ),
            403
        );
        assert_eq!(ask(&with(&s.token), ""), 403, "{path} without Host");
    }
    // The token in its header serves as well as in the query.
    let header = format!("Host: {host}\r\nX-Campath-Token: {}\r\n", s.token);
    assert_eq!(ask("/api/state", &header), 200);

    // A write from another origin, or with none, is refused; from the page's own it is served.
    let body = format!(r#"{{"base":"{}"}}"#, s.sha());
    assert_eq!(
        s.post_from("/api/undo", &body, Some("http://evil.example"))
            .0,
        403
    );
    let other_port = format!("http://127.0.0.1:{}", s.port + 1);
    assert_eq!(s.post_from("/api/undo", &body, Some(&other_port)).0, 403);
    assert_eq!(s.post_from("/api/undo", &body, None).0, 403);
    let (status, answer) = s.post("/api/undo", &body);
    assert_eq!(
        (status, answer.contains("nothing to undo")),
        (422, true),
        "{answer}"
    );

    // Bad requests get a 4xx, and the studio goes on answering.
    for (path, want) in [
        ("/api/view?frame=24", 400),
        ("/api/view?frame=-1", 400),
        ("/api/view?frame=0&vrp=1,2", 400),
        ("/api/view?frame=0&vrp=nan,0,0", 400),
        ("/api/view?frame=0&width=0", 400),
        ("/api/view?frame=0&cop=0,0,1", 400),
        ("/api/view?frame=0&vpn=0,0,0", 400),
        ("/etc/passwd", 404),
        ("/../s.ron", 404),
    ] {
        assert_eq!(s.get(path).0, want, "{path}");
    }
    for body in [
        "",
        "{",
        r#"{"base":"x","track":"Observer","op":"set"}"#,
        "[1,2]",
        &format!(
            r#"{{"base":"{}","track":"Nope","op":"set","t":0,"value":[1,2,3]}}"#,
            s.sha()
        ),
        &format!(
            r#"{{"base":"{}","track":"Observer","op":"set","t":-1,"value":[1,2,3]}}"#,
            s.sha()
        ),
        &format!(
            r#"{{"base":"{}","track":"Observer","op":"set","t":0,"value":[1,2]}}"#,
            s.sha()
        ),
        &format!(
            r#"{{"base":"{}","track":"Zoom","op":"set","t":0,"value":[1e400]}}"#,
            s.sha()
        ),
        &format!(
            r#"{{"base":"{}","track":"Observer","op":"delete","index":9}}"#,
            s.sha()
        ),
        &format!(r#"{{"base":"{}","track":"Observer","op":"jump"}}"#, s.sha()),
        &format!(r#"{{"base":"{}","path":"/etc/passwd"}}"#, s.sha()),
    ] {
        let (status, answer) = s.post("/api/key", body);
        assert!((400..500).contains(&status), "{body}: {status} {answer}");
    }
    let big = format!(r#"{{"base":"{}"}}"#, "x".repeat(100_000));
    assert_eq!(s.post("/api/key", &big).0, 413);
    assert_eq!(s.get("/api/view?frame=3&width=32").0, 200);
    // Nothing of all this wrote the file.
    assert_eq!(std::fs::read_to_string(&file).unwrap(), FILE);
}

#[test]
fn two_hundred_requests_at_once_and_a_stuck_client_leave_the_page_answering() {
    let tmp = tempfile::tempdir().unwrap();
    shot(tmp.path());
    let s = start(tmp.path(), "s.ron", &[]);
    // Two clients that never finish: one mid-headers, one mid-body.
    let mut stuck = TcpStream::connect(("127.0.0.1", s.port)).unwrap();
    stuck
        .write_all(format!("GET /api/state?token={} HTTP/1.1\r\nHost: ", s.token).as_bytes())
        .unwrap();
    let mut stuck_body = TcpStream::connect(("127.0.0.1", s.port)).unwrap();
    let head = format!(
        "POST /api/key HTTP/1.1\r\nHost: {}\r\nOrigin: http://{}\r\nX-Campath-Token: {}\r\n\
         Content-Length: 1000\r\n\r\n{{\"base\":",
        s.host(),
        s.host(),
        s.token
    );
    stuck_body.write_all(head.as_bytes()).unwrap();

    let answers: Vec<u16> = std::thread::scope(|scope| {
        let asks: Vec<_> = (0..200)
            .map(|i| {
                let s = &s;
                scope.spawn(move || match i % 4 {
                    0 => s.get(&format!("/api/view?frame={}&width=32", i % 24)).0,
                    1 => s.get("/api/shot").0,
                    2 => s.get("/").0,
                    _ => s.get("/api/state").0,
                })
            })
            .collect();
        asks.into_iter().map(|a| a.join().unwrap()).collect()
    });
    assert!(answers.iter().all(|&a| a == 200), "{answers:?}");
    assert_eq!(s.get("/").0, 200);
    assert_eq!(s.get("/api/view?frame=5&width=64").0, 200);
    drop((stuck, stuck_body));
}

#[test]
fn a_key_changes_only_its_tracks_keys_and_undo_gives_back_every_byte() {
    let tmp = tempfile::tempdir().unwrap();
    let file = shot(tmp.path());
    let s = start(tmp.path(), "s.ron", &[]);
    let set = format!(
        r#"{{"base":"{}","track":"Observer","op":"set","t":0.75,"value":[1.25,2.0000004,-5.5]}}"#,
        s.sha()
    );
    let (status, answer) = s.post("/api/key", &set);
    assert_eq!(status, 200, "{answer}");
    let after = std::fs::read_to_string(&file).unwrap();
    let (start_before, end_before) = keys_span(FILE, "Observer");
    let (start_after, end_after) = keys_span(&after, "Observer");
    assert_eq!(
        after[..start_after],
        FILE[..start_before],
        "before the keys"
    );
    assert_eq!(after[end_after..], FILE[end_before..], "after the keys");
    // The new key, rounded to a millionth, sits between the two, and both keep their text.
    let keys = &after[start_after..end_after];
    let at = |k: &str| keys.find(k).unwrap_or_else(|| panic!("{k} not in {keys}"));
    assert!(
        at("(t: 0.0, value: (0.0, 1.0, -6.0)), // start")
            < at("(t: 0.75, value: (1.25, 2.0, -5.5))")
    );
    assert!(at("(t: 0.75, value: (1.25, 2.0, -5.5))") < at("(t: 1.5, value: (2.0, 1.5, -5.0))"));
    // The file still loads, and its path passes through the key at its frame (0.75 s × 12 fps).
    let o = campath(tmp.path(), &["path", "s.ron", "--format", "csv"], &[]);
    let line = stdout(&o)
        .lines()
        .find(|l| l.starts_with("9,"))
        .unwrap()
        .to_string();
    assert!(line.starts_with("9,0.75,1.25,2,-5.5,"), "{line}");
    let state = s.state_where(|v| v["undo"].is_string());
    assert_eq!(state["undo"], "set the Observer key at 0.75 s");

    let base = state["sha"].as_str().unwrap().to_string();
    let (status, answer) = s.post("/api/undo", &format!(r#"{{"base":"{base}"}}"#));
    assert_eq!(status, 200, "{answer}");
    assert_eq!(std::fs::read_to_string(&file).unwrap(), FILE, "undo");
    let base = s.state_where(|v| v["redo"].is_string())["sha"]
        .as_str()
        .unwrap()
        .to_string();
    assert_eq!(
        s.post("/api/redo", &format!(r#"{{"base":"{base}"}}"#)).0,
        200
    );
    assert_eq!(std::fs::read_to_string(&file).unwrap(), after, "redo");

    // Move and delete, each undone to the same bytes.
    for edit in [
        r#""track":"Observer","op":"move","index":2,"t":1.0"#,
        r#""track":"Observer","op":"delete","index":0"#,
        r#""track":"Distort","op":"set","t":0.5,"value":[0.25,-0.125]"#,
        r#""track":"Zoom","op":"set","t":1.0,"value":[-2.5]"#,
    ] {
        let before = std::fs::read_to_string(&file).unwrap();
        let (status, answer) = s.post("/api/key", &format!(r#"{{"base":"{}",{edit}}}"#, s.sha()));
        assert_eq!(status, 200, "{edit}: {answer}");
        assert_ne!(std::fs::read_to_string(&file).unwrap(), before, "{edit}");
        assert_eq!(
            s.post("/api/undo", &format!(r#"{{"base":"{}"}}"#, s.sha()))
                .0,
            200
        );
        assert_eq!(
            std::fs::read_to_string(&file).unwrap(),
            before,
            "{edit} undone"
        );
    }
    // An edit that would make the file invalid is refused, and writes nothing: a LookAround
    // track beside the Track track (both set the view direction), or the Track track's only key
    // deleted (then nothing sets it).
    for bad in [
        r#""track":"LookAround","op":"set","t":0.0,"value":[0,0,1]"#,
        r#""track":"Track","op":"delete","index":0"#,
    ] {
        let (status, answer) = s.post("/api/key", &format!(r#"{{"base":"{}",{bad}}}"#, s.sha()));
        assert_eq!(status, 422, "{answer}");
        assert!(answer.contains("nothing was written"), "{answer}");
        assert_eq!(std::fs::read_to_string(&file).unwrap(), after);
    }
}

#[test]
fn an_edit_from_the_editor_is_never_written_over() {
    let tmp = tempfile::tempdir().unwrap();
    let file = shot(tmp.path());
    let s = start(tmp.path(), "s.ron", &[]);
    let seen = s.sha();
    // The editor saves, and the page, which has not heard of it, sets a key at once.
    let edited = FILE.replace("// start", "// start, as the editor says");
    std::fs::write(&file, &edited).unwrap();
    let set = format!(
        r#"{{"base":"{seen}","track":"Observer","op":"set","t":0.5,"value":[1.0,1.0,-6.0]}}"#
    );
    let (status, answer) = s.post("/api/key", &set);
    assert_eq!(status, 409, "{answer}");
    assert_eq!(std::fs::read_to_string(&file).unwrap(), edited);
    // The page hears of the save, with a notice; a key set on it is written over the editor's
    // text, which it keeps.
    let state = s.state_where(|v| v["sha"] != seen.as_str());
    assert!(state["text"]
        .as_str()
        .unwrap()
        .contains("as the editor says"));
    let again = set.replace(&seen, state["sha"].as_str().unwrap());
    assert_eq!(s.post("/api/key", &again).0, 200);
    let now = std::fs::read_to_string(&file).unwrap();
    assert!(
        now.contains("as the editor says") && now.contains("(t: 0.5, value: (1.0, 1.0, -6.0))"),
        "{now}"
    );
    // A save outside ends the studio's undo history: undo would write over it.
    std::fs::write(&file, FILE).unwrap();
    let state = s.state_where(|v| v["text"] == FILE);
    assert!(state["undo"].is_null(), "{state}");
    assert!(state["notice"]
        .as_str()
        .unwrap()
        .contains("saved outside the studio"));
    let undo = format!(r#"{{"base":"{}"}}"#, state["sha"].as_str().unwrap());
    assert_eq!(s.post("/api/undo", &undo).0, 422);
    assert_eq!(std::fs::read_to_string(&file).unwrap(), FILE);

    // A read-only file, and one with another hard link (which a rename would part from it),
    // are refused, naming why; nothing is written.
    use std::os::unix::fs::PermissionsExt;
    let key = |sha: &str| {
        format!(r#"{{"base":"{sha}","track":"Zoom","op":"set","t":0.5,"value":[-2.0]}}"#)
    };
    std::fs::set_permissions(&file, std::fs::Permissions::from_mode(0o444)).unwrap();
    let (status, answer) = s.post("/api/key", &key(&s.sha()));
    assert_eq!(status, 422, "{answer}");
    assert!(answer.contains("read-only"), "{answer}");
    std::fs::set_permissions(&file, std::fs::Permissions::from_mode(0o640)).unwrap();
    std::fs::hard_link(&file, tmp.path().join("other.ron")).unwrap();
    let (status, answer) = s.post("/api/key", &key(&s.sha()));
    assert!(status == 422 && answer.contains("hard links"), "{answer}");
    assert_eq!(std::fs::read_to_string(&file).unwrap(), FILE);
    // Once alone again, the key is written, and the file keeps its permissions.
    std::fs::remove_file(tmp.path().join("other.ron")).unwrap();
    assert_eq!(s.post("/api/key", &key(&s.sha())).0, 200);
    let mode = std::fs::metadata(&file).unwrap().permissions().mode();
    assert_eq!(mode & 0o777, 0o640);
}

#[test]
fn a_read_only_studio_and_a_broken_save_write_nothing_and_keep_the_last_good_shot() {
    let tmp = tempfile::tempdir().unwrap();
    let file = shot(tmp.path());
    let s = start(tmp.path(), "s.ron", &["--read-only"]);
    let set = format!(
        r#"{{"base":"{}","track":"Observer","op":"set","t":0.5,"value":[1.0,1.0,-6.0]}}"#,
        s.sha()
    );
    assert_eq!(s.post("/api/key", &set).0, 403);
    assert_eq!(std::fs::read_to_string(&file).unwrap(), FILE);
    // A broken save: its error is shown, the last good shot still renders.
    std::fs::write(&file, "(frames: 6,").unwrap();
    let state = s.state_where(|v| v["error"].is_string());
    assert_eq!(state["good_version"], 1, "{state}");
    assert_eq!(s.get("/api/view?frame=23&width=32").0, 200);
    // A file that is not UTF-8 is an error, not a panic.
    std::fs::write(&file, b"(frames: \xff)").unwrap();
    let state = s.state_where(|v| v["error"].as_str().is_some_and(|e| e.contains("UTF-8")));
    assert_eq!(state["good_version"], 1);
    std::fs::write(&file, FILE).unwrap();
    let state = s.state_where(|v| v["error"].is_null());
    assert!(state["good_version"].as_u64() > Some(1));
}

/// The path of `node`'s puppeteer-core, through NODE_PATH, or why there is none.
fn puppeteer_missing(node: &str) -> Option<String> {
    let o = Command::new(node)
        .args(["-e", "require.resolve('puppeteer-core')"])
        .output();
    match o {
        Ok(o) if o.status.success() => None,
        Ok(_) => Some(
            "node cannot find puppeteer-core: npm install puppeteer-core and set NODE_PATH".into(),
        ),
        Err(e) => Some(format!("node does not run: {e}")),
    }
}

fn node(args: &[&str]) {
    let o = Command::new("node")
        .arg(root().join("tests/it/studio.mjs"))
        .args(args)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "studio.mjs {args:?}: {}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}

/// The pixels the page's view held, as studio.mjs wrote them.
fn page_pixels(path: &Path) -> (u32, u32, Vec<u8>) {
    use base64::Engine;
    let text = std::fs::read_to_string(path).unwrap();
    let (head, body) = text.split_once('\n').unwrap();
    let head: serde_json::Value = serde_json::from_str(head).unwrap();
    let rgb = base64::engine::general_purpose::STANDARD
        .decode(body.trim())
        .unwrap();
    let size = |k: &str| head[k].as_u64().unwrap() as u32;
    (size("width"), size("height"), rgb)
}

/// `campath render`'s frame `frame` of `file` (in `dir`), as RGB8.
fn rendered(dir: &Path, file: &str, frame: u64) -> (u32, u32, Vec<u8>) {
    let out = dir.join(format!("render-{file}"));
    let o = campath(
        dir,
        &[
            "render",
            file,
            "--out",
            out.to_str().unwrap(),
            "--frames",
            &format!("{frame}..{}", frame + 1),
        ],
        &[],
    );
    assert!(o.status.success(), "{}", crate::common::stderr(&o));
    let png = std::fs::read_dir(&out)
        .unwrap()
        .flatten()
        .find(|e| e.file_name().to_string_lossy().starts_with("frame_"))
        .unwrap()
        .path();
    let img = image::open(png).unwrap().to_rgb8();
    (img.width(), img.height(), img.into_raw())
}

#[test]
#[ignore = "needs chromium, and node with puppeteer-core (NODE_PATH)"]
fn the_page_scrubs_to_render_s_pixels_flies_a_key_undoes_and_refuses_a_stale_edit() {
    need_part("chromium", "chromium", does_not_run);
    need_part("node", "nodejs", puppeteer_missing);
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    // The example at its own size (640×360, 2×2 samples) and the same shot at the page's preview
    // size (640 wide, the file's aspect, one sample).
    let text = std::fs::read_to_string(root().join("animations/flythrough.ron")).unwrap();
    std::fs::write(dir.join("fly.ron"), &text).unwrap();
    std::fs::write(
        dir.join("small.ron"),
        text.replace("samples: 2", "samples: 1"),
    )
    .unwrap();
    let s = start(dir, "fly.ron", &[]);
    let out = dir.join("seen");
    node(&[
        "flow",
        &s.url,
        dir.join("fly.ron").to_str().unwrap(),
        out.to_str().unwrap(),
        "37",
    ]);

    assert_eq!(
        page_pixels(&out.join("preview.json")),
        rendered(dir, "small.ron", 37),
        "preview"
    );
    assert_eq!(
        page_pixels(&out.join("full.json")),
        rendered(dir, "fly.ron", 37),
        "exact frame"
    );

    let flow: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("flow.json")).unwrap()).unwrap();
    assert!(
        flow["label"].as_str().unwrap().starts_with("frame 37 / 95"),
        "{flow}"
    );
    // The flown key: at 37 / 24 s, the flown VRP rounded to a millionth; every byte outside the
    // Observer track's keys as it was, comments included.
    let after = std::fs::read_to_string(out.join("after-set.ron")).unwrap();
    let (a, b) = keys_span(&text, "Observer");
    let (c, d) = keys_span(&after, "Observer");
    assert_eq!((&after[..c], &after[d..]), (&text[..a], &text[b..]));
    let vrp: Vec<f64> = flow["flown"]["vrp"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    let number = |x: f64| {
        let x = (x * 1e6).round() / 1e6;
        let t = format!("{x:?}");
        if t == "-0.0" {
            "0.0".to_string()
        } else {
            t
        }
    };
    let key = format!(
        "(t: {:?}, value: ({}, {}, {}))",
        37.0 / 24.0,
        number(vrp[0]),
        number(vrp[1]),
        number(vrp[2])
    );
    assert!(after[c..d].contains(&key), "{key} not in {}", &after[c..d]);
    assert!(
        flow["afterSet"]
            .as_str()
            .unwrap()
            .contains("set the Observer key"),
        "{flow}"
    );
    // Undo: the file byte for byte as it was.
    assert_eq!(
        std::fs::read_to_string(out.join("after-undo.ron")).unwrap(),
        text
    );
    // The edit behind the page: the key is refused, the file keeps the editor's text, and the
    // page shows it.
    let edited = text.replacen("// ", "// edited in the editor: ", 1);
    assert_eq!(
        std::fs::read_to_string(out.join("after-refusal.ron")).unwrap(),
        edited
    );
    assert!(
        flow["refused"]
            .as_str()
            .unwrap()
            .contains("nothing was written"),
        "{flow}"
    );
    assert_eq!(flow["shown"], edited.as_str());
}

#[test]
#[ignore = "needs chromium, and node with puppeteer-core (NODE_PATH)"]
fn the_timeline_shows_check_s_warnings_at_their_frames() {
    need_part("chromium", "chromium", does_not_run);
    need_part("node", "nodejs", puppeteer_missing);
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    // The camera passes through a sphere: the COP is inside it for some frames.
    let text = FILE.replace(
        "(center: (1.5, 0.0, 1.0), radius: 0.5)",
        "(center: (1.17, 1.47, -6.46), radius: 0.3)",
    );
    std::fs::write(dir.join("w.ron"), &text).unwrap();
    let check = stdout(&campath(dir, &["check", "w.ron"], &[]));
    let warnings: Vec<&str> = check
        .lines()
        .filter_map(|l| l.strip_prefix("warning: "))
        .collect();
    assert!(
        check.contains("warning: frames 7, 8, 9, 10: the COP is inside"),
        "{check}"
    );
    let s = start(dir, "w.ron", &["--read-only"]);
    let out = dir.join("warnings.json");
    node(&["warnings", &s.url, out.to_str().unwrap()]);
    let seen: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let markers = seen["markers"].as_array().unwrap();
    assert_eq!(markers.len(), warnings.len(), "{seen}");
    for (m, w) in markers.iter().zip(&warnings) {
        assert_eq!(m["text"], *w);
        // "frame 7: …" or "frames 7–9: …": the marker is at the first.
        let first: u64 = w
            .trim_start_matches("frames ")
            .trim_start_matches("frame ")
            .split(|c: char| !c.is_ascii_digit())
            .next()
            .unwrap()
            .parse()
            .unwrap();
        assert_eq!(m["frame"], first, "{w}");
    }
    assert_eq!(seen["shown"], warnings[0]);
    let inside = markers
        .iter()
        .find(|m| m["text"].as_str().unwrap().contains("COP is inside"));
    assert_eq!(inside.unwrap()["frame"], 7);
}

/// The file's sphere in colour `k`.
fn coloured(k: u8) -> String {
    FILE.replace("(0.9, 0.2, 0.2)", &format!("(0.9, 0.2, 0.{k})"))
}

/// Sends `child` SIGINT, as Ctrl-C does, through the shell's own `kill` (a machine with only
/// Rust may have no `kill` program).
fn ctrl_c(child: &Child) {
    let kill = Command::new("sh")
        .args(["-c", &format!("kill -INT {}", child.id())])
        .status()
        .unwrap();
    assert!(kill.success());
}

/// `campath watch` is the studio's page, read-only: it follows the file through a link, its
/// target edited, its folder removed and made again, and a save in two steps (the file emptied,
/// then written) is never shown as an error; Ctrl-C exits 0; an earlier watch's options are
/// refused with the fix.
#[test]
fn watch_is_the_read_only_studio_and_follows_the_file_however_it_is_replaced() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    std::fs::create_dir_all(t.join("real")).unwrap();
    std::fs::create_dir_all(t.join("shots")).unwrap();
    std::fs::write(t.join("real/w.ron"), coloured(1)).unwrap();
    std::os::unix::fs::symlink("../real/w.ron", t.join("shots/w.ron")).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_campath"))
        .current_dir(t)
        .args(["watch", "shots/w.ron"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
    let head = lines.next().unwrap().unwrap();
    assert!(head.contains("(read-only)"), "{head}");
    let url = lines.next().unwrap().unwrap();
    std::thread::spawn(move || lines.for_each(drop));
    let rest = url.strip_prefix("open http://127.0.0.1:").unwrap();
    let (port, token) = rest.split_once("/?token=").unwrap();
    let s = Studio {
        child,
        port: port.parse().unwrap(),
        token: token.to_string(),
        url: url.clone(),
    };
    let shows =
        |k: u8| s.state_where(|v| v["text"] == coloured(k).as_str() && v["error"].is_null());
    shows(1);
    let set = format!(
        r#"{{"base":"{}","track":"Observer","op":"set","t":0.5,"value":[1.0,1.0,-6.0]}}"#,
        s.sha()
    );
    assert_eq!(s.post("/api/key", &set).0, 403, "read-only");
    // The link's target edited in place.
    std::fs::write(t.join("real/w.ron"), coloured(2)).unwrap();
    shows(2);
    // The target's folder removed and made again.
    std::fs::remove_dir_all(t.join("real")).unwrap();
    s.state_where(|v| v["error"].is_string());
    std::fs::create_dir_all(t.join("real")).unwrap();
    std::fs::write(t.join("real/w.ron"), coloured(3)).unwrap();
    let good = shows(3)["good_version"].as_u64().unwrap();
    // A save in two steps, 100 ms apart: the empty file is never shown as an error.
    let mut f = std::fs::File::create(t.join("real/w.ron")).unwrap();
    std::thread::sleep(Duration::from_millis(100));
    f.write_all(coloured(4).as_bytes()).unwrap();
    drop(f);
    let state = shows(4);
    assert!(state["good_version"].as_u64() > Some(good));
    assert_eq!(
        std::fs::read_to_string(t.join("real/w.ron")).unwrap(),
        coloured(4)
    );
    let mut s = s;
    ctrl_c(&s.child);
    assert_eq!(s.child.wait().unwrap().code(), Some(0));

    // An earlier watch's options: refused, naming the fix; a file that is not there: exit 2.
    for args in [
        &["watch", "shots/w.ron", "--out", "page"][..],
        &["watch", "shots/w.ron", "--width", "48"],
        &["watch", "nowhere/w.ron"],
    ] {
        let o = campath(t, args, &[]);
        assert_eq!(o.status.code(), Some(2), "{args:?}");
        let err = crate::common::stderr(&o);
        assert!(err.lines().count() == 1, "{err}");
        if args.len() > 2 {
            assert!(
                err.contains("leave") && err.contains("out and open the address"),
                "{err}"
            );
        }
    }
    assert!(!t.join("page").exists());
}
