//! The studio's writes of the shot file: a key set, moved or deleted, and undo and redo.
//!
//! Each write changes one track's `keys: [...]` text and no other byte (`format::splice`), and
//! happens only when the page names the bytes the file has on disk (their fingerprint): a save
//! from the user's editor since the page loaded the file refuses the write, and the page shows
//! the file as saved. The new text must make a valid document, or nothing is written. The file
//! is written through a temporary file beside it and a rename, keeping its permissions (and a
//! link: the link's target is written).
//!
//! Undo writes back the bytes before the studio's last edit, redo the bytes after it, each only
//! while the file still has the bytes that edit left.

use std::sync::Arc;

use serde::Deserialize;

use super::{load, Studio};
use crate::format::splice::{self, KeyEdit};
use crate::mode::Mode;

/// One write of the studio: the file's bytes before and after, and what it did, in words.
pub struct Change {
    pub before: Arc<Vec<u8>>,
    pub after: Arc<Vec<u8>>,
    pub what: String,
}

/// `POST /api/key`: `{"base": FINGERPRINT, "track": "Observer", "op": "set", "t": 2.0,
/// "value": [x, y, z]}`; `"op": "move"` takes `"index"` and `"t"`, `"delete"` takes `"index"`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct KeyRequest {
    base: String,
    track: String,
    op: String,
    t: Option<f64>,
    index: Option<usize>,
    value: Option<Vec<f64>>,
}

/// `POST /api/undo` and `/api/redo`: `{"base": FINGERPRINT}`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct HistoryRequest {
    base: String,
}

/// A refused edit: its status and why.
type Refused = (u16, String);

/// Applies the request at `path` to the file. The answer's status and JSON body: the new
/// state's version, or 409 (the file changed), or 422 (the edit cannot be made, or would make
/// the file invalid).
pub fn apply(studio: &Studio, path: &str, body: &str) -> (u16, String) {
    let _writing = studio.writing.lock().unwrap_or_else(|p| p.into_inner());
    match write(studio, path, body) {
        Ok(what) => (200, serde_json::json!({"done": what}).to_string()),
        Err((status, why)) => (status, serde_json::json!({"error": why}).to_string()),
    }
}

fn write(studio: &Studio, path: &str, body: &str) -> Result<String, Refused> {
    let base = match path {
        "/api/key" => parse::<KeyRequest>(body)?.base,
        _ => parse::<HistoryRequest>(body)?.base,
    };
    let (bytes, sha) = {
        let s = studio.lock();
        (Arc::clone(&s.bytes), s.sha.clone())
    };
    // The page's copy first; the disk's is compared last, just before the rename (`save`).
    if base != sha {
        return Err((
            409,
            "the page's copy of the file is out of date (it was saved since): nothing was \
             written; the page now shows the file as it is, make the edit again"
                .into(),
        ));
    }
    let (after, what, undoing) = match path {
        "/api/key" => {
            let request: KeyRequest = parse(body)?;
            let (text, what) = key_edit(&bytes, &request)?;
            (Arc::new(text.into_bytes()), what, None)
        }
        "/api/undo" | "/api/redo" => {
            let undo = path == "/api/undo";
            let s = studio.lock();
            let stack = if undo { &s.undo } else { &s.redo };
            let Some(change) = stack.last() else {
                return Err((422, format!("nothing to {}", &path[5..])));
            };
            let (from, to) = match undo {
                true => (&change.after, &change.before),
                false => (&change.before, &change.after),
            };
            if **from != **bytes {
                return Err((409, "the file is not as the studio's edit left it".into()));
            }
            (Arc::clone(to), change.what.clone(), Some(undo))
        }
        _ => return Err((404, "no such page".into())),
    };
    let good = load(&studio.file, &after).map_err(|e| {
        (
            422,
            format!("the edit would make the file invalid, so nothing was written: {e}"),
        )
    })?;
    // The new text is checked before the disk's bytes are compared, so that the compare and the
    // rename come one straight after the other (a check of a large scene takes seconds).
    save(&studio.file, &bytes, &after)?;
    // No stamp: the watch reads the file once more and finds the bytes the studio holds (or an
    // editor's save, made since, which it then shows).
    let stamp = None;
    let notice = match undoing {
        Some(true) => format!("undone: {what}"),
        Some(false) => format!("redone: {what}"),
        None => what.clone(),
    };
    {
        let mut s = studio.lock();
        match undoing {
            Some(true) => {
                let change = s.undo.pop().expect("checked above");
                s.redo.push(change);
            }
            Some(false) => {
                let change = s.redo.pop().expect("checked above");
                s.undo.push(change);
            }
            None => {
                s.redo.clear();
                s.undo.push(Change {
                    before: Arc::clone(&bytes),
                    after: Arc::clone(&after),
                    what: what.clone(),
                });
            }
        }
    }
    studio.install(after.to_vec(), stamp, Some(notice), Ok(good));
    Ok(what)
}

fn parse<'a, T: Deserialize<'a>>(body: &'a str) -> Result<T, Refused> {
    serde_json::from_str(body).map_err(|e| (400, format!("the request is not understood: {e}")))
}

/// The file's text with the request's key edit made, and the edit in words.
fn key_edit(bytes: &[u8], r: &KeyRequest) -> Result<(String, String), Refused> {
    let bad = |why: String| (422, why);
    let text = std::str::from_utf8(bytes).map_err(|_| bad("the file is not UTF-8".into()))?;
    let mode = Mode::ALL
        .into_iter()
        .find(|m| m.name() == r.track)
        .ok_or_else(|| {
            let names: Vec<&str> = Mode::ALL.iter().map(|m| m.name()).collect();
            bad(format!("track {:?}: one of {}", r.track, names.join(", ")))
        })?;
    let t = |t: Option<f64>| match t {
        Some(t) if t.is_finite() && t >= 0.0 => Ok(t),
        _ => Err(bad("t: a time in seconds, ≥ 0".into())),
    };
    let index = || {
        r.index
            .ok_or_else(|| bad("index: the key's number, from 0".into()))
    };
    let (edit, what) = match r.op.as_str() {
        "set" => {
            let t = t(r.t)?;
            let value = value_text(mode, r.value.as_deref().unwrap_or(&[])).map_err(bad)?;
            let what = format!("set the {mode} key at {} s", splice::number(t));
            (KeyEdit::Set { t, value }, what)
        }
        "move" => {
            let (index, t) = (index()?, t(r.t)?);
            let what = format!("moved {mode} key {index} to {} s", splice::number(t));
            (KeyEdit::Move { index, t }, what)
        }
        "delete" => {
            let index = index()?;
            (
                KeyEdit::Delete { index },
                format!("deleted {mode} key {index}"),
            )
        }
        op => return Err(bad(format!("op {op:?}: set, move or delete"))),
    };
    let edited = splice::edit_keys(text, mode, &edit).map_err(|e| bad(e.to_string()))?;
    Ok((edited, what))
}

/// A key's value as the file writes it: the VRP, TP or VPN as `(x, y, z)`, the COP's n or the
/// roll in degrees as a number, the COP's (u, v) as a pair. Values are rounded to 1e-6 (a millionth of a world unit):
/// what a hand-written key would give, and no digits of rounding noise in the file.
fn value_text(mode: Mode, value: &[f64]) -> Result<String, String> {
    let want = match mode {
        Mode::Observer | Mode::LookAround | Mode::Track => 3,
        Mode::Zoom | Mode::Roll => 1,
        Mode::Distort => 2,
    };
    if value.len() != want || !value.iter().all(|x| x.is_finite() && x.abs() < 1e12) {
        return Err(format!("value: {want} finite number(s) for a {mode} key"));
    }
    let round = |x: f64| splice::number((x * 1e6).round() / 1e6);
    let parts: Vec<String> = value.iter().map(|&x| round(x)).collect();
    Ok(match want {
        1 => parts[0].clone(),
        _ => format!("({})", parts.join(", ")),
    })
}

/// Writes `after` to the shot file through a temporary file beside it (beside a link's
/// target, for a link), with the file's permissions, renamed into place, but only while the file
/// still holds `before`: compared once the temporary file is written, just before the rename.
/// A read-only file, or one with other hard links (which a rename would part from it), is
/// refused.
fn save(file: &std::path::Path, before: &[u8], after: &[u8]) -> Result<(), Refused> {
    use std::io::Write;
    let target = crate::output::resolved(file);
    let said =
        |e: &dyn std::fmt::Display| (500, format!("{}: cannot write: {e}", target.display()));
    let meta = std::fs::metadata(&target).map_err(|e| said(&e))?;
    if meta.permissions().readonly() {
        return Err((
            422,
            format!("{}: the file is read-only; nothing was written (make it writable, or run the studio with --read-only)", target.display()),
        ));
    }
    #[cfg(unix)]
    if std::os::unix::fs::MetadataExt::nlink(&meta) > 1 {
        return Err((
            422,
            format!("{}: the file has other hard links, which a write by rename would part from it; nothing was written (edit a copy, or a symbolic link to it)", target.display()),
        ));
    }
    let mut tmp = crate::output::temp_beside(&target).map_err(|e| said(&e))?;
    tmp.write_all(after).map_err(|e| said(&e))?;
    tmp.as_file().sync_all().map_err(|e| said(&e))?;
    std::fs::set_permissions(tmp.path(), meta.permissions()).map_err(|e| said(&e))?;
    if std::fs::read(&target).map_err(|e| said(&e))? != before {
        return Err((
            409,
            "the file changed on disk since the page loaded it: nothing was written, and the \
             page now shows the file as it is; make the edit again"
                .into(),
        ));
    }
    tmp.persist(&target).map_err(|e| said(&e.error))?;
    Ok(())
}
