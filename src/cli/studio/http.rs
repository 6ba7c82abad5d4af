//! The studio's door: who may ask (token, `Host`, `Origin`), the routes, and the answers.
//! Every request is answered; a bad one gets a 4xx, never a panic.

use std::io::Read;
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use glam::DVec3;
use tiny_http::{Header, Method, Request, Response};

use super::{Studio, LONG_POLL};
use crate::output::{encode_png, Compression};

/// The header a script may send the token in, instead of `?token=`.
const TOKEN_HEADER: &str = "X-Campath-Token";

/// The largest request body read: an edit is a few hundred bytes.
const MAX_BODY: u64 = 64 * 1024;

/// The longest file the page shows as text (a file with a long inline sphere list is not).
const SHOWN_TEXT: usize = 256 * 1024;

/// The page: HTML, CSS and JavaScript, no network.
const PAGE: &str = include_str!("page.html");

pub type Answer = Response<std::io::Cursor<Vec<u8>>>;

/// 32 bytes from the system's random source, as 64 hex digits: the one value in campath that
/// is random on purpose, so that no other page or local user can guess it. It never reaches a
/// picture.
pub fn new_token() -> super::Result<String> {
    let mut bytes = [0u8; 32];
    getrandom::fill(&mut bytes).map_err(|e| {
        super::CliError::Tool("getrandom", format!("no random source for the token: {e}"))
    })?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

fn header(name: &str, value: &str) -> Header {
    Header::from_bytes(name.as_bytes(), value.as_bytes()).expect("ASCII header")
}

/// An answer with the headers every answer carries: nothing cached, nothing sniffed, not
/// framed by another page, no address (with its token) sent on as a referrer.
fn answer(status: u16, content_type: &str, body: Vec<u8>) -> Answer {
    Response::from_data(body)
        .with_status_code(status)
        .with_header(header("Content-Type", content_type))
        .with_header(header("Cache-Control", "no-store"))
        .with_header(header("X-Content-Type-Options", "nosniff"))
        .with_header(header("X-Frame-Options", "DENY"))
        .with_header(header("Referrer-Policy", "no-referrer"))
        .with_header(header(
            "Content-Security-Policy",
            "default-src 'none'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; \
             img-src 'self' blob:; connect-src 'self'; frame-ancestors 'none'; base-uri 'none'; \
             form-action 'none'",
        ))
}

pub fn text(status: u16, body: &str) -> Answer {
    answer(
        status,
        "text/plain; charset=utf-8",
        body.as_bytes().to_vec(),
    )
}

pub fn json(status: u16, body: String) -> Answer {
    answer(status, "application/json", body.into_bytes())
}

/// The value of the request's header `name`, if it has exactly one.
fn one_header<'a>(request: &'a Request, name: &'static str) -> Option<&'a str> {
    let mut values = request
        .headers()
        .iter()
        .filter(|h| h.field.equiv(name))
        .map(|h| h.value.as_str());
    let first = values.next()?;
    values.next().is_none().then_some(first)
}

/// The query's value of `name` (the first), percent-decoded.
pub fn query<'a>(url: &'a str, name: &str) -> Option<std::borrow::Cow<'a, str>> {
    let (_, q) = url.split_once('?')?;
    q.split('&').find_map(|pair| {
        let (k, v) = pair.split_once('=').unwrap_or((pair, ""));
        (k == name).then(|| decode(v))
    })
}

fn decode(v: &str) -> std::borrow::Cow<'_, str> {
    if !v.contains(['%', '+']) {
        return v.into();
    }
    let b = v.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        match b[i] {
            b'%' if i + 2 < b.len() => match (hex(b[i + 1]), hex(b[i + 2])) {
                (Some(h), Some(l)) => {
                    out.push((h * 16 + l) as u8);
                    i += 3;
                    continue;
                }
                _ => out.push(b'%'),
            },
            b'+' => out.push(b' '),
            c => out.push(c),
        }
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned().into()
}

/// Equal strings, compared in a time that does not depend on where they differ.
fn same(a: &str, b: &str) -> bool {
    a.len() == b.len()
        && a.bytes()
            .zip(b.bytes())
            .fold(0u8, |acc, (x, y)| acc | (x ^ y))
            == 0
}

/// Why a request may not be served (403), or None.
fn forbidden(studio: &Studio, request: &Request) -> Option<&'static str> {
    let port = studio.port;
    let hosts = [format!("127.0.0.1:{port}"), format!("localhost:{port}")];
    match one_header(request, "Host") {
        Some(host) if hosts.iter().any(|h| h.eq_ignore_ascii_case(host)) => {}
        _ => return Some("forbidden: the Host is not the studio's address"),
    }
    let token = one_header(request, TOKEN_HEADER)
        .map(std::borrow::Cow::from)
        .or_else(|| query(request.url(), "token"));
    if !token.is_some_and(|t| same(&t, &studio.token)) {
        return Some("forbidden: open the address `campath studio` printed, with its token");
    }
    if *request.method() != Method::Get && *request.method() != Method::Head {
        let origins = hosts.map(|h| format!("http://{h}"));
        match one_header(request, "Origin") {
            Some(o) if origins.iter().any(|h| h.eq_ignore_ascii_case(o)) => {}
            _ => return Some("forbidden: a write must come from the studio's own page (Origin)"),
        }
    }
    None
}

/// Answers one request.
pub fn serve(studio: &Arc<Studio>, mut request: Request) {
    let reply = match forbidden(studio, &request) {
        Some(why) => text(403, why),
        None => route(studio, &mut request),
    };
    let _ = request.respond(reply);
}

fn route(studio: &Arc<Studio>, request: &mut Request) -> Answer {
    let url = request.url().to_string();
    let path = url.split('?').next().unwrap_or("");
    let method = request.method().clone();
    match (method, path) {
        (Method::Get, "/") => answer(200, "text/html; charset=utf-8", PAGE.as_bytes().to_vec()),
        (Method::Get, "/api/state") => state(studio, &url),
        (Method::Get, "/api/shot") => {
            let shot = Arc::clone(&studio.lock().shot_json);
            json(200, shot.as_str().to_owned())
        }
        (Method::Get, "/api/view") => view(studio, &url),
        (Method::Post, "/api/key" | "/api/undo" | "/api/redo") => {
            let mut body = String::new();
            let len = request.body_length().unwrap_or(0) as u64;
            if len > MAX_BODY {
                return text(413, "the request's body is too large");
            }
            if request
                .as_reader()
                .take(MAX_BODY + 1)
                .read_to_string(&mut body)
                .is_err()
                || body.len() as u64 > MAX_BODY
            {
                return text(
                    400,
                    "the request's body is not UTF-8 text of at most 64 KiB",
                );
            }
            if studio.read_only {
                return text(403, "read-only: this studio does not write the file");
            }
            let (status, body) = super::edit::apply(studio, path, &body);
            json(status, body)
        }
        (
            _,
            "/" | "/api/state" | "/api/shot" | "/api/view" | "/api/key" | "/api/undo" | "/api/redo",
        ) => text(405, "method not allowed"),
        _ => text(404, "no such page"),
    }
}

/// The state's JSON, once its version passes `since` (or after [`LONG_POLL`]).
fn state(studio: &Studio, url: &str) -> Answer {
    let since = query(url, "since").and_then(|v| v.parse::<u64>().ok());
    let started = Instant::now();
    let mut s = studio.lock();
    while since.is_some_and(|v| s.version <= v) && started.elapsed() < LONG_POLL {
        let left = LONG_POLL.saturating_sub(started.elapsed());
        s = studio
            .changed
            .wait_timeout(s, left)
            .unwrap_or_else(|p| p.into_inner())
            .0;
    }
    let body = serde_json::json!({
        "version": s.version,
        "sha": s.sha,
        "good_version": s.good_version,
        "error": s.error,
        "notice": s.notice,
        "undo": s.undo.last().map(|c| &c.what),
        "redo": s.redo.last().map(|c| &c.what),
        "read_only": studio.read_only,
        "file": studio.file.display().to_string(),
        "text": (s.bytes.len() <= SHOWN_TEXT).then(|| String::from_utf8_lossy(&s.bytes)),
    });
    json(200, body.to_string())
}

fn triple(url: &str, name: &str) -> Result<Option<DVec3>, String> {
    let Some(v) = query(url, name) else {
        return Ok(None);
    };
    let xs: Vec<f64> = v
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("{name}={v}: three numbers x,y,z"))?;
    match xs[..] {
        [x, y, z] if xs.iter().all(|x| x.is_finite()) => Ok(Some(DVec3::new(x, y, z))),
        _ => Err(format!("{name}={v}: three finite numbers x,y,z")),
    }
}

/// A PNG of a frame: at the preview size, or at the file's own (`full=1`).
fn view(studio: &Studio, url: &str) -> Answer {
    let Some(good) = studio.lock().good.clone() else {
        return text(409, "the file has no valid version yet");
    };
    let doc = &good.doc;
    let frames = doc.animation.frames;
    let frame = match query(url, "frame").map(|f| f.parse::<u64>()) {
        Some(Ok(k)) if k < frames => k,
        _ => return text(400, &format!("frame: a frame from 0 to {}", frames - 1)),
    };
    let flown = (|| {
        Ok::<_, String>((
            triple(url, "vrp")?,
            triple(url, "vpn")?,
            triple(url, "cop")?,
        ))
    })();
    let (vrp, vpn, cop) = match flown {
        Ok(parts) => parts,
        Err(e) => return text(400, &e),
    };
    let full = query(url, "full").is_some_and(|f| f == "1");
    let still = (vrp, vpn, cop) == (None, None, None);
    let (cameras, raster) = if full {
        let cameras = if still {
            match doc.exposure(frame) {
                Ok(e) => e.renders().to_vec(),
                Err(e) => return text(409, &e.to_string()),
            }
        } else {
            match good.flown(frame, vrp, vpn, cop) {
                Ok(c) => vec![c],
                Err(e) => return text(400, &e),
            }
        };
        (cameras, doc.raster)
    } else {
        let width = match query(url, "width").map(|w| w.parse::<u32>()) {
            Some(Ok(w)) if (1..=16384).contains(&w) => w,
            None => 640,
            _ => return text(400, "width: 1 to 16384 pixels"),
        };
        match good.flown(frame, vrp, vpn, cop) {
            Ok(c) => (vec![c], super::shot::preview_raster(doc, width)),
            Err(e) => return text(400, &e),
        }
    };
    let started = Instant::now();
    let pixels = match (full, still) {
        (false, true) => good.preview(frame, raster),
        _ => good.render(cameras, raster),
    };
    let Some(pixels) = pixels else {
        return text(503, "the renderer stopped");
    };
    let rendered = started.elapsed().as_secs_f64() * 1e3;
    let size = (raster.width, raster.height);
    // `format=rgb`: the pixels as they are (RGB8, rows top first), which the page draws with no
    // encoding or decoding on the way; else a PNG.
    let (body, kind) = if query(url, "format").is_some_and(|f| f == "rgb") {
        (pixels.to_vec(), "application/octet-stream")
    } else {
        let mut png = Vec::new();
        let encoded = encode_png(
            Path::new("<view>"),
            &mut png,
            &pixels,
            size,
            Compression::Fast,
        );
        if encoded.is_err() {
            return text(500, "cannot encode the picture");
        }
        (png, "image/png")
    };
    let timing = format!(
        "render;dur={rendered:.1}, total;dur={:.1}",
        started.elapsed().as_secs_f64() * 1e3
    );
    answer(200, kind, body)
        .with_header(header("X-Campath-Size", &format!("{}x{}", size.0, size.1)))
        .with_header(header("Server-Timing", &timing))
}
