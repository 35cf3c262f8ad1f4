//! `raylab serve`: a small local web server (std TCP, `httparse`; see [`http`]) showing a live
//! session.
//!
//! Routes, and nothing else (every other path is a 404; no part of a request ever names a
//! file, so nothing on disk can be reached through it):
//!
//! - `GET /`: the page (self-contained HTML, CSS and script; see [`page`]).
//! - `GET /image.png`: the latest image, tonemapped, from memory (503 before the first).
//! - `GET /state[?since=N]`: JSON: version, scene, selection, load error, render statistics,
//!   and the image's version and integrator. With `since`, waits up to [`LONG_POLL`] (or
//!   `wait=MS`, if shorter) for a version above N (long polling).
//! - `GET /integrators`: JSON: every integrator with its parameters (name, kind, default,
//!   min, max, doc), from the registry.
//! - `GET /settings`: the current selection; `POST /settings` (JSON
//!   `{"integrator": NAME, "params": {NAME: VALUE}, "sampler": NAME}`) switches integrator,
//!   parameters and sampler,
//!   checked by the registry: a bad one is a 400 with the registry's message.
//!
//! Every request is answered on its own thread (at most [`MAX_ACTIVE`] at once, then 503, and
//! at most half of them waiting in long polls), under the limits of [`http`]: a bounded head
//! and body, and a deadline for a slow client; a client that goes away mid-response only makes
//! that write fail, which is ignored. Requests whose `Host` is not the loopback address are
//! refused when bound to loopback (DNS rebinding), and `POST` needs this page's origin (or
//! none) and exactly a JSON content type (no cross-site posts).

pub mod http;
pub mod page;

use super::{Control, Ended, Observer, RenderInfo, Selection};
use crate::output::{self, DisplaySettings};
use crate::render::{Film, RenderStats};
use anyhow::{anyhow, Result};
use http::Request;
use raylab_integrators::sampler::SamplerKind;
use raylab_integrators::{registry, ParamKind};
use serde_json::{json, Value};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant};

/// Longest wait of a `/state?since=N` request.
pub const LONG_POLL: Duration = Duration::from_secs(2);
/// Requests answered at once; more get a 503.
pub const MAX_ACTIVE: usize = 32;
/// Long polls that may wait at once (half the slots): the rest of the slots stay free for
/// the page's other requests, however many tabs poll.
pub const MAX_WAITING: usize = MAX_ACTIVE / 2;
/// Largest `POST /settings` body.
const MAX_BODY: usize = 64 * 1024;

/// The latest image, PNG-encoded.
struct Image {
    png: Arc<Vec<u8>>,
    version: u64,
    integrator: &'static str,
    params: String,
    spp: u32,
}

/// The render in progress (or the last one).
struct Status {
    /// Counts renders, so the page knows when one restarts.
    id: u64,
    info: RenderInfo,
    stats: RenderStats,
    state: &'static str,
}

/// What the page sees; every change bumps `version`.
#[derive(Default)]
struct State {
    version: u64,
    renders: u64,
    image: Option<Image>,
    status: Option<Status>,
    error: Option<String>,
    selection: Selection,
}

/// The state shared by the session (writer) and the request threads (readers).
pub struct Shared {
    scene: String,
    state: Mutex<State>,
    changed: Condvar,
}

impl Shared {
    /// Shared state for `scene` (shown on the page) and the starting selection.
    pub fn new(scene: &str, selection: Selection) -> Arc<Shared> {
        Arc::new(Shared {
            scene: scene.to_string(),
            state: Mutex::new(State {
                selection,
                ..State::default()
            }),
            changed: Condvar::new(),
        })
    }

    fn lock(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Applies `f` and wakes the long polls.
    fn update(&self, f: impl FnOnce(&mut State)) {
        let mut s = self.lock();
        f(&mut s);
        s.version += 1;
        self.changed.notify_all();
    }

    /// The `/state` JSON.
    fn state_json(&self, s: &State) -> Value {
        let selection = json!({
            "integrator": s.selection.integrator,
            "sampler": s.selection.sampler.map(SamplerKind::name),
            "params": s
                .selection
                .params
                .iter()
                .map(|(k, v)| (k.clone(), Value::from(v.clone())))
                .collect::<serde_json::Map<String, Value>>(),
        });
        let render = s.status.as_ref().map(|st| {
            let params: serde_json::Map<String, Value> = st
                .info
                .params
                .iter()
                .map(|(k, v)| (k.to_string(), Value::from(v.clone())))
                .collect();
            json!({
                "id": st.id,
                "state": st.state,
                "integrator": st.info.integrator,
                "params": params,
                "sampler": st.info.sampler.name(),
                "describe": st.info.describe_params(),
                "width": st.info.width,
                "height": st.info.height,
                "target_spp": st.info.target_spp,
                "spp": st.stats.spp_done,
                "elapsed_s": st.stats.elapsed.as_secs_f64(),
                "samples_per_s": st.stats.samples_per_second(),
                "rays_per_s": st.stats.rays_per_second(),
                "rays": {
                    "camera": st.stats.rays.camera,
                    "extension": st.stats.rays.extension,
                    "shadow": st.stats.rays.shadow,
                    "light": st.stats.rays.light,
                    "connection": st.stats.rays.connection,
                },
                "dropped": st.stats.dropped.count,
            })
        });
        let image = s.image.as_ref().map(|i| {
            json!({"version": i.version, "integrator": i.integrator, "params": i.params, "spp": i.spp})
        });
        json!({
            "version": s.version,
            "scene": self.scene,
            "samplers": SamplerKind::ALL.iter().map(|(n, _)| *n).collect::<Vec<_>>(),
            "selection": selection,
            "error": s.error,
            "render": render,
            "image": image,
        })
    }
}

/// Turns the session's reports into the page's state.
pub struct PageObserver {
    shared: Arc<Shared>,
    display: DisplaySettings,
    quiet: bool,
}

impl PageObserver {
    pub fn new(shared: Arc<Shared>, display: DisplaySettings, quiet: bool) -> PageObserver {
        PageObserver {
            shared,
            display,
            quiet,
        }
    }
}

impl Observer for PageObserver {
    fn render_started(&mut self, info: &RenderInfo) {
        if !self.quiet {
            note!(
                "rendering {}: {} {} | {}x{}",
                self.shared.scene,
                info.integrator,
                info.describe_params(),
                info.width,
                info.height
            );
        }
        self.shared.update(|s| {
            s.error = None;
            s.renders += 1;
            s.status = Some(Status {
                id: s.renders,
                info: info.clone(),
                stats: RenderStats::default(),
                state: "rendering",
            });
        });
    }

    fn image(&mut self, film: &Film, info: &RenderInfo, stats: &RenderStats) {
        let img = output::to_srgb_image(film, self.display);
        let mut png = Vec::new();
        if let Err(e) = img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png) {
            note!("error: cannot encode the image: {e}");
            return;
        }
        self.shared.update(|s| {
            let version = s.version + 1;
            s.image = Some(Image {
                png: Arc::new(png),
                version,
                integrator: info.integrator,
                params: info.describe_params(),
                spp: stats.spp_done,
            });
            if let Some(st) = &mut s.status {
                st.stats = stats.clone();
            }
        });
    }

    fn render_ended(&mut self, _info: &RenderInfo, stats: &RenderStats, why: Ended) {
        self.shared.update(|s| {
            if let Some(st) = &mut s.status {
                st.stats = stats.clone();
                st.state = match why {
                    Ended::Finished => "finished",
                    Ended::Changed => "restarting",
                    Ended::Quit => "stopped",
                };
            }
        });
    }

    fn load_failed(&mut self, message: &str) {
        note!("error: {message}");
        self.shared.update(|s| s.error = Some(message.to_string()));
    }

    fn reloaded(&mut self, line: &str) {
        if !self.quiet {
            note!("{line}");
        }
    }
}

/// The `/integrators` JSON.
fn integrators_json() -> Value {
    let number = |v: f64| if v.is_finite() { json!(v) } else { Value::Null };
    Value::Array(
        registry::REGISTRY
            .iter()
            .map(|e| {
                let params: Vec<Value> = e
                    .params
                    .iter()
                    .map(|p| {
                        json!({
                            "name": p.name,
                            "kind": p.kind.name(),
                            "choices": match p.kind {
                                ParamKind::Choice(names) => json!(names),
                                _ => Value::Null,
                            },
                            "default": p.default_text(),
                            "min": number(p.min),
                            "max": number(p.max),
                            "doc": p.doc,
                        })
                    })
                    .collect();
                json!({"name": e.name, "summary": e.summary, "params": params})
            })
            .collect(),
    )
}

/// Reads a `POST /settings` body into a selection, checked by the registry.
fn parse_selection(body: &[u8]) -> Result<Selection> {
    let v: Value = serde_json::from_slice(body).map_err(|e| anyhow!("bad JSON: {e}"))?;
    let obj = v.as_object().ok_or_else(|| {
        anyhow!("expected a JSON object {{\"integrator\": ..., \"params\": {{...}}}}")
    })?;
    if let Some(k) = obj
        .keys()
        .find(|k| !["integrator", "params", "sampler"].contains(&k.as_str()))
    {
        return Err(anyhow!(
            "unknown field `{k}`; expected `integrator`, `params` and `sampler`"
        ));
    }
    let sampler = match obj.get("sampler") {
        None | Some(Value::Null) => None,
        Some(Value::String(s)) => Some(SamplerKind::parse(s).map_err(|e| anyhow!("{e}"))?),
        Some(_) => return Err(anyhow!("`sampler` must be a string")),
    };
    let integrator = match obj.get("integrator") {
        None | Some(Value::Null) => None,
        Some(Value::String(s)) => Some(s.clone()),
        Some(_) => return Err(anyhow!("`integrator` must be a string")),
    };
    let mut params = Vec::new();
    match obj.get("params") {
        None | Some(Value::Null) => {}
        Some(Value::Object(m)) => {
            for (k, v) in m {
                let text = match v {
                    Value::String(s) => s.clone(),
                    Value::Number(n) => n.to_string(),
                    _ => return Err(anyhow!("parameter `{k}`: expected a number or a string")),
                };
                params.push((k.clone(), text));
            }
        }
        Some(_) => return Err(anyhow!("`params` must be an object")),
    }
    let selection = Selection {
        integrator,
        params,
        sampler,
    };
    selection.check()?;
    Ok(selection)
}

/// A response: status, content type, body.
struct Reply {
    status: u16,
    content_type: &'static str,
    body: Arc<Vec<u8>>,
}

impl Reply {
    fn text(status: u16, text: impl Into<String>) -> Reply {
        let mut t = text.into();
        t.push('\n');
        Reply {
            status,
            content_type: "text/plain; charset=utf-8",
            body: Arc::new(t.into_bytes()),
        }
    }

    fn json(v: &Value) -> Reply {
        Reply {
            status: 200,
            content_type: "application/json",
            body: Arc::new(v.to_string().into_bytes()),
        }
    }
}

/// What the request threads share.
struct Context {
    shared: Arc<Shared>,
    control: Arc<Control>,
    /// Accepted `Host` headers; `None` accepts any.
    hosts: Option<Vec<String>>,
    active: AtomicUsize,
    /// Long polls waiting now.
    waiting: AtomicUsize,
}

/// Decrements a count (active requests, waiting long polls) when it is dropped, however the
/// request ends.
struct ActiveGuard<'a>(&'a AtomicUsize);

impl Drop for ActiveGuard<'_> {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::SeqCst);
    }
}

fn query_value<'a>(query: &'a str, key: &str) -> Option<&'a str> {
    query
        .split('&')
        .filter_map(|kv| kv.split_once('='))
        .find(|(k, _)| *k == key)
        .map(|(_, v)| v)
}

impl Context {
    fn host_ok(&self, request: &Request) -> bool {
        let Some(hosts) = &self.hosts else {
            return true;
        };
        request
            .header("Host")
            .is_some_and(|h| hosts.iter().any(|ok| h.eq_ignore_ascii_case(ok)))
    }

    /// `GET /state?since=N[&wait=MS]`: waits for a version above N, at most `wait`. At most
    /// [`MAX_WAITING`] requests wait at once; more are answered at once, so that waiting
    /// clients never hold every request slot.
    fn state(&self, since: Option<u64>, wait: Duration) -> Reply {
        let shared = &self.shared;
        let may_wait = since.is_some() && self.waiting.fetch_add(1, Ordering::SeqCst) < MAX_WAITING;
        let _waiting = since.is_some().then(|| ActiveGuard(&self.waiting));
        let mut s = shared.lock();
        if let (Some(since), true) = (since, may_wait) {
            let end = Instant::now() + wait;
            while s.version <= since && !self.control.is_quitting() {
                let left = end.saturating_duration_since(Instant::now());
                if left.is_zero() {
                    break;
                }
                s = shared
                    .changed
                    .wait_timeout(s, left.min(Duration::from_millis(250)))
                    .unwrap_or_else(|e| e.into_inner())
                    .0;
            }
        }
        Reply::json(&shared.state_json(&s))
    }

    fn post_settings(&self, request: &Request) -> Reply {
        // Another site's page may post to this address; a browser sends its Origin. Only
        // this page's own origin (or none, from a client that is no browser) may change the
        // settings.
        if let Some(origin) = request.header("Origin") {
            let host = request.header("Host").unwrap_or("");
            if !origin.eq_ignore_ascii_case(&format!("http://{host}")) {
                return Reply::text(403, "POST /settings is only taken from this page's origin");
            }
        }
        // Exactly JSON (parameters such as a charset aside): a cross-site form or a plain
        // text body is no settings request.
        let media_type = request.header("Content-Type").map(|t| {
            t.split(';')
                .next()
                .unwrap_or("")
                .trim()
                .to_ascii_lowercase()
        });
        if media_type.as_deref() != Some("application/json") {
            return Reply::text(415, "POST /settings takes Content-Type: application/json");
        }
        match parse_selection(&request.body) {
            Ok(selection) => {
                self.shared.update(|s| s.selection = selection.clone());
                self.control.select(selection);
                self.settings()
            }
            Err(e) => Reply::text(400, format!("{e:#}")),
        }
    }

    fn settings(&self) -> Reply {
        let s = self.shared.lock();
        Reply::json(&self.shared.state_json(&s)["selection"])
    }

    fn route(&self, request: &Request) -> Reply {
        if !self.host_ok(request) {
            return Reply::text(
                403,
                "this server answers only requests addressed to it by its loopback address",
            );
        }
        let url = request.url.as_str();
        let (path, query) = url.split_once('?').unwrap_or((url, ""));
        let method = request.method.as_str();
        let get = matches!(method, "GET" | "HEAD");
        match (path, get) {
            ("/", true) => Reply {
                status: 200,
                content_type: "text/html; charset=utf-8",
                body: Arc::new(page::page().as_bytes().to_vec()),
            },
            ("/image.png", true) => match &self.shared.lock().image {
                Some(i) => Reply {
                    status: 200,
                    content_type: "image/png",
                    body: Arc::clone(&i.png),
                },
                None => Reply::text(503, "no image yet"),
            },
            ("/state", true) => {
                let since = query_value(query, "since").and_then(|v| v.parse::<u64>().ok());
                let wait = query_value(query, "wait")
                    .and_then(|v| v.parse::<u64>().ok())
                    .map_or(LONG_POLL, |ms| Duration::from_millis(ms).min(LONG_POLL));
                self.state(since, wait)
            }
            ("/integrators", true) => Reply::json(&integrators_json()),
            ("/settings", true) => self.settings(),
            ("/settings", false) if method == "POST" => self.post_settings(request),
            ("/" | "/image.png" | "/state" | "/integrators" | "/settings", false) => {
                Reply::text(405, "method not allowed")
            }
            _ => Reply::text(404, "not found"),
        }
    }

    /// Reads one request from `stream` and answers it.
    fn handle(&self, mut stream: TcpStream) {
        let request = match http::read_request(&mut stream, MAX_BODY) {
            Ok(r) => r,
            Err(http::ReadError::Gone) => return,
            Err(http::ReadError::Status(status, why)) => {
                let reply = Reply::text(status, why);
                http::respond(
                    &mut stream,
                    status,
                    &[("Content-Type", reply.content_type)],
                    &reply.body,
                    false,
                );
                return;
            }
        };
        let reply = self.route(&request);
        http::respond(
            &mut stream,
            reply.status,
            &[
                ("Content-Type", reply.content_type),
                ("Cache-Control", "no-store"),
                ("X-Content-Type-Options", "nosniff"),
                ("X-Frame-Options", "DENY"),
                (
                    "Content-Security-Policy",
                    "default-src 'none'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; img-src 'self' data:; connect-src 'self'",
                ),
            ],
            &reply.body,
            request.method == "HEAD",
        );
    }
}

/// A bound server, not yet answering.
pub struct Server {
    listener: TcpListener,
    addr: SocketAddr,
    context: Arc<Context>,
}

impl Server {
    /// Binds `host:port` (port 0: any free port).
    pub fn bind(
        host: &str,
        port: u16,
        shared: Arc<Shared>,
        control: Arc<Control>,
    ) -> Result<Server> {
        let listener = TcpListener::bind((host, port))
            .map_err(|e| anyhow!("cannot listen on {host}:{port}: {e}"))?;
        let addr = listener
            .local_addr()
            .map_err(|e| anyhow!("{host}:{port}: {e}"))?;
        // Accepting in turns with checking whether the session quit.
        listener
            .set_nonblocking(true)
            .map_err(|e| anyhow!("{host}:{port}: {e}"))?;
        let hosts = addr.ip().is_loopback().then(|| {
            let p = addr.port();
            vec![
                format!("127.0.0.1:{p}"),
                format!("localhost:{p}"),
                format!("[::1]:{p}"),
                addr.to_string(),
            ]
        });
        Ok(Server {
            listener,
            addr,
            context: Arc::new(Context {
                shared,
                control,
                hosts,
                active: AtomicUsize::new(0),
                waiting: AtomicUsize::new(0),
            }),
        })
    }

    /// The address bound.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// The page's address.
    pub fn url(&self) -> String {
        format!("http://{}/", self.addr)
    }

    /// Answers requests, each on its own thread, until the control quits.
    pub fn run(&self) {
        while !self.context.control.is_quitting() {
            let mut stream = match self.listener.accept() {
                Ok((stream, _)) => stream,
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                    std::thread::sleep(Duration::from_millis(20));
                    continue;
                }
                Err(e) => {
                    note!("warning: serve: {e}");
                    std::thread::sleep(Duration::from_millis(20));
                    continue;
                }
            };
            // Connections block (with the deadlines of `http`); only the listener polls.
            if stream.set_nonblocking(false).is_err() {
                continue;
            }
            let ctx = Arc::clone(&self.context);
            if ctx.active.fetch_add(1, Ordering::SeqCst) >= MAX_ACTIVE {
                ctx.active.fetch_sub(1, Ordering::SeqCst);
                let busy = Reply::text(503, "busy");
                http::respond(
                    &mut stream,
                    503,
                    &[("Content-Type", busy.content_type)],
                    &busy.body,
                    false,
                );
                continue;
            }
            let spawned = std::thread::Builder::new()
                .name("raylab-http".into())
                .spawn(move || {
                    let _guard = ActiveGuard(&ctx.active);
                    ctx.handle(stream);
                });
            if let Err(e) = spawned {
                // The closure (and its guard) never ran: undo the count by hand.
                self.context.active.fetch_sub(1, Ordering::SeqCst);
                note!("warning: serve: cannot start a thread: {e}");
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_bodies_are_checked() {
        let ok =
            parse_selection(br#"{"integrator": "whitted", "params": {"max-depth": 3}}"#).unwrap();
        assert_eq!(ok.integrator.as_deref(), Some("whitted"));
        assert_eq!(ok.params, vec![("max-depth".to_string(), "3".to_string())]);
        assert_eq!(ok.sampler, None);
        // The page's sampler menu and a choice parameter's menu.
        let ok = parse_selection(
            br#"{"integrator": "path", "params": {"light-selection": "bvh"}, "sampler": "zsobol"}"#,
        )
        .unwrap();
        assert_eq!(ok.sampler, Some(SamplerKind::ZSobol));
        assert_eq!(
            ok.params,
            vec![("light-selection".to_string(), "bvh".to_string())]
        );
        for (body, expected) in [
            (
                &br#"{"integrator": "path", "sampler": "pmj"}"#[..],
                "no sampler `pmj`",
            ),
            (
                br#"{"integrator": "path", "sampler": 2}"#,
                "`sampler` must be a string",
            ),
            (
                br#"{"integrator": "path", "params": {"light-selection": "best"}}"#,
                "`best` is not one of scene, uniform, power, bvh",
            ),
            (
                &br#"{"integrator": "nope"}"#[..],
                "unknown integrator `nope`",
            ),
            (
                br#"{"integrator": "path", "params": {"max-depth": -2}}"#,
                "out of range",
            ),
            (
                br#"{"integrator": "path", "params": {"bogus": 1}}"#,
                "no parameter `bogus`",
            ),
            (br#"{"integrator": 3}"#, "must be a string"),
            (br#"{"other": 3}"#, "unknown field"),
            (b"[1, 2", "bad JSON"),
        ] {
            let e = format!("{:#}", parse_selection(body).unwrap_err());
            assert!(e.contains(expected), "{e}");
        }
    }

    #[test]
    fn integrators_json_lists_the_registry() {
        let v = integrators_json();
        let list = v.as_array().unwrap();
        assert_eq!(list.len(), registry::REGISTRY.len());
        let path = list.iter().find(|e| e["name"] == "path").unwrap();
        let depth = path["params"]
            .as_array()
            .unwrap()
            .iter()
            .find(|p| p["name"] == "max-depth")
            .unwrap();
        assert_eq!(depth["kind"], "depth");
    }
}
