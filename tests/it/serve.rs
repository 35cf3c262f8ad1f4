//! `raylab serve` over HTTP as a browser and a hostile client would use it: the routes, 404
//! for every other path (no file is ever served), 400 with the registry's message for bad
//! settings, clients that disconnect mid-request or mid-response, the load error shown while
//! the scene is broken, saves and new settings applied to the session's world (the `reload:`
//! line says what was rebuilt), and the page itself in headless Chromium switching the
//! integrator.

use crate::common;

use common::{
    break_scene, chromium, chromium_dump_dom, eventually, save, scene_copy, Running, CORNELL_LIGHT,
    TIMEOUT,
};
use serde_json::Value;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::path::Path;

/// A running `raylab serve` and its address.
struct Served {
    run: Running,
    addr: SocketAddr,
}

/// `raylab serve SCENE --port 0` at 32x32, `spp` spp, one thread; reads the address from
/// the first line of stdout.
fn serve(scene: &Path, spp: &str) -> Served {
    let mut run = Running::start(
        &[
            "serve",
            scene.to_str().unwrap(),
            "--port",
            "0",
            "--size",
            "32x32",
            "--spp",
            spp,
            "--threads",
            "1",
        ],
        &scene.with_extension("stderr"),
        true,
    );
    let stdout = run.child.stdout.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut line = String::new();
        let _ = BufReader::new(stdout).read_line(&mut line);
        let _ = tx.send(line);
    });
    let line = rx
        .recv_timeout(TIMEOUT)
        .unwrap_or_else(|_| panic!("no address printed; stderr:\n{}", run.stderr()));
    let url = line
        .trim()
        .strip_prefix("serving http://")
        .and_then(|u| u.strip_suffix('/'))
        .unwrap_or_else(|| panic!("unexpected first line {line:?}"));
    Served {
        addr: url.parse().unwrap(),
        run,
    }
}

/// A response: status, headers (lowercased names), body.
struct Reply {
    status: u16,
    headers: String,
    body: Vec<u8>,
}

impl Reply {
    fn text(&self) -> String {
        String::from_utf8_lossy(&self.body).into_owned()
    }

    fn json(&self) -> Value {
        serde_json::from_slice(&self.body).unwrap_or_else(|e| panic!("{e}: {}", self.text()))
    }
}

impl Served {
    /// Sends `raw` (a whole request) and reads the whole response.
    fn raw(&self, raw: &str) -> Reply {
        let mut s = TcpStream::connect(self.addr).unwrap();
        s.set_read_timeout(Some(TIMEOUT)).unwrap();
        s.write_all(raw.as_bytes()).unwrap();
        let mut all = Vec::new();
        s.read_to_end(&mut all).unwrap();
        let split = all
            .windows(4)
            .position(|w| w == b"\r\n\r\n")
            .expect("a complete response");
        let head = String::from_utf8_lossy(&all[..split]).to_lowercase();
        let status = head.split_whitespace().nth(1).unwrap().parse().unwrap();
        Reply {
            status,
            headers: head,
            body: all[split + 4..].to_vec(),
        }
    }

    fn get(&self, path: &str) -> Reply {
        self.raw(&format!(
            "GET {path} HTTP/1.1\r\nHost: {}\r\nConnection: close\r\n\r\n",
            self.addr
        ))
    }

    fn post(&self, path: &str, content_type: &str, body: &str) -> Reply {
        self.raw(&format!(
            "POST {path} HTTP/1.1\r\nHost: {}\r\nContent-Type: {content_type}\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{body}",
            self.addr,
            body.len()
        ))
    }

    fn state(&self) -> Value {
        let r = self.get("/state");
        assert_eq!(r.status, 200);
        r.json()
    }

    /// Polls `/state` until `f` holds.
    fn wait_state(&self, what: &str, f: impl Fn(&Value) -> bool) -> Value {
        let mut last = Value::Null;
        if eventually(|| {
            last = self.state();
            f(&last)
        }) {
            return last;
        }
        panic!(
            "timed out waiting for {what}; state {last}; stderr:\n{}",
            self.run.stderr()
        );
    }
}

fn finished(s: &Value) -> bool {
    s["render"]["state"] == "finished" && s["image"].is_object()
}

#[test]
fn serves_its_routes_and_nothing_else_and_survives_bad_clients() {
    let (_dir, scene) = scene_copy("cornell_box.ron");
    let srv = serve(&scene, "4");

    let page = srv.get("/");
    assert_eq!(page.status, 200);
    assert!(page.headers.contains("content-type: text/html"));
    let html = page.text();
    assert!(html.contains("<select id=\"integrator\">") && html.contains("/state?since="));
    assert!(
        !html.contains("http://") && !html.contains("https://"),
        "self-contained"
    );

    let list = srv.get("/integrators").json();
    let names: Vec<&str> = list
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["name"].as_str().unwrap())
        .collect();
    assert!(
        names.contains(&"path") && names.contains(&"whitted"),
        "{names:?}"
    );

    let s = srv.wait_state("the first image", finished);
    assert_eq!(s["render"]["integrator"], "path");
    assert_eq!(
        s["render"]["params"]["max-depth"], "7",
        "the scene's parameters"
    );
    assert_eq!(s["render"]["spp"], 4);
    assert!(s["render"]["rays_per_s"].as_f64().unwrap() > 0.0);
    assert!(s["error"].is_null());
    let png = srv.get("/image.png");
    assert_eq!(png.status, 200);
    assert!(png.headers.contains("content-type: image/png"));
    let img = image::load_from_memory(&png.body).unwrap();
    assert_eq!((img.width(), img.height()), (32, 32));

    // Long polling: an old version answers at once, a current one waits for a change.
    let v = s["version"].as_u64().unwrap();
    assert_eq!(srv.get("/state?since=0").json()["version"], v);

    // Nothing but the routes: no path reaches the file system.
    for path in [
        "/Cargo.toml",
        "/../Cargo.toml",
        "/%2e%2e/Cargo.toml",
        "/image.png/../../Cargo.toml",
        "//etc/passwd",
        "/scenes/cornell_box.ron",
        "/index.html",
        "/state/",
    ] {
        let r = srv.get(path);
        assert_eq!(r.status, 404, "{path}");
        assert!(!r.text().contains("[package]"));
    }
    let r = srv.raw(&format!(
        "DELETE / HTTP/1.1\r\nHost: {}\r\nConnection: close\r\n\r\n",
        srv.addr
    ));
    assert_eq!(r.status, 405);
    // Another site's name for this address (DNS rebinding) is refused.
    let r = srv.raw("GET /state HTTP/1.1\r\nHost: evil.example:80\r\nConnection: close\r\n\r\n");
    assert_eq!(r.status, 403);

    // Bad settings: 400 with the registry's message; a form post (another site) is refused.
    for (body, expected) in [
        (r#"{"integrator": "nope"}"#, "unknown integrator `nope`"),
        (
            r#"{"integrator": "path", "params": {"max-depth": "-3"}}"#,
            "out of range",
        ),
        (
            r#"{"integrator": "whitted", "params": {"bogus": 1}}"#,
            "no parameter `bogus`",
        ),
        ("not json", "bad JSON"),
    ] {
        let r = srv.post("/settings", "application/json", body);
        assert_eq!(r.status, 400, "{body}");
        assert!(r.text().contains(expected), "{body}: {}", r.text());
    }
    let r = srv.post("/settings", "text/plain", r#"{"integrator": "whitted"}"#);
    assert_eq!(r.status, 415);
    assert_eq!(
        srv.state()["render"]["integrator"],
        "path",
        "nothing changed"
    );

    // Clients that go away: mid-request, mid-long-poll, mid-response.
    {
        let mut a = TcpStream::connect(srv.addr).unwrap();
        a.write_all(b"GET /sta").unwrap();
        let mut b = TcpStream::connect(srv.addr).unwrap();
        write!(
            b,
            "GET /state?since={v} HTTP/1.1\r\nHost: {}\r\n\r\n",
            srv.addr
        )
        .unwrap();
        for _ in 0..20 {
            let mut c = TcpStream::connect(srv.addr).unwrap();
            write!(c, "GET /image.png HTTP/1.1\r\nHost: {}\r\n\r\n", srv.addr).unwrap();
            let mut first = [0u8; 10];
            let _ = c.read(&mut first);
        }
        let _ = (a.shutdown(std::net::Shutdown::Both), b);
    }
    let silent = TcpStream::connect(srv.addr).unwrap(); // connects, never speaks
    assert_eq!(srv.get("/state").status, 200, "still answering");

    // A valid switch: the next image is by whitted.
    let r = srv.post(
        "/settings",
        "application/json",
        r#"{"integrator": "whitted", "params": {"max-depth": 3}}"#,
    );
    assert_eq!(r.status, 200, "{}", r.text());
    let s = srv.wait_state("an image by whitted", |s| {
        finished(s) && s["image"]["integrator"] == "whitted"
    });
    assert_eq!(s["render"]["params"]["max-depth"], "3");
    assert_eq!(s["selection"]["integrator"], "whitted");
    drop(silent);

    assert_eq!(srv.run.interrupt().code(), Some(0));
}

#[test]
fn shows_the_load_error_while_the_scene_is_broken_and_reloads_on_save() {
    let (_dir, scene) = scene_copy("cornell_box.ron");
    let srv = serve(&scene, "4");
    let s = srv.wait_state("the first image", finished);
    let image_version = s["image"]["version"].clone();
    let good = srv.get("/image.png").body;

    let (text, at) = break_scene(&scene);
    let s = srv.wait_state("the load error", |s| s["error"].is_string());
    let error = s["error"].as_str().unwrap();
    assert!(error.contains(&at), "{error}");
    assert_eq!(s["image"]["version"], image_version, "the last image stays");
    assert_eq!(srv.get("/image.png").body, good);

    save(
        &scene,
        &text.replace(CORNELL_LIGHT, "radiance: (1.5, 1.5, 1.5)"),
    );
    let s = srv.wait_state("the render after the fix", |s| {
        s["error"].is_null() && finished(s) && s["image"]["version"] != image_version
    });
    assert_ne!(srv.get("/image.png").body, good);
    // The session kept its world: the fix was applied as an edit of it.
    let e = srv.run.stderr();
    assert!(
        e.contains("reload: 1 entity changed (emitter), rebuilt the light table"),
        "{e}"
    );

    // Another integrator rebuilds nothing.
    let version = s["image"]["version"].clone();
    let r = srv.post(
        "/settings",
        "application/json",
        r#"{"integrator": "whitted"}"#,
    );
    assert_eq!(r.status, 200, "{}", r.text());
    srv.wait_state("whitted's image", |s| {
        s["image"]["integrator"] == "whitted" && s["image"]["version"] != version
    });
    assert!(eventually(|| srv
        .run
        .stderr()
        .contains("new integrator or parameters, rebuilt nothing")));
    assert_eq!(srv.run.interrupt().code(), Some(0));
}

/// Opens the page with `#selftest=whitted` in headless Chromium: the page switches the menu
/// to whitted, waits for whitted's image to arrive and load, and reports in its title.
#[test]
fn the_page_switches_the_integrator_in_headless_chromium() {
    let Some(chromium) = chromium() else {
        return;
    };
    let (_dir, scene) = scene_copy("cornell_box.ron");
    let srv = serve(&scene, "16");
    let url = format!("http://{}/#selftest=whitted", srv.addr);
    let (dom, console) = chromium_dump_dom(chromium, &url, 30_000);
    assert!(
        dom.contains("<title>selftest: ok</title>"),
        "page self-test failed: {}\nverdict: {}\nraylab stderr:\n{}",
        dom.lines()
            .find(|l| l.contains("<title>"))
            .unwrap_or("no title"),
        dom.lines()
            .find(|l| l.contains("id=\"verdict\""))
            .unwrap_or("no verdict"),
        srv.run.stderr()
    );
    assert!(console.is_empty(), "console messages: {console:#?}");
    // The server agrees: the switch went through the menu to the session.
    let s = srv.state();
    assert_eq!(s["selection"]["integrator"], "whitted");
    assert_eq!(s["image"]["integrator"], "whitted");
    assert_eq!(srv.run.interrupt().code(), Some(0));
}

/// A pass that would take hours (fixed-depth, depth 5, branching 64: 17 million rays per
/// sample) does not wedge the session: new settings abandon it at once. Settings no pass can
/// finish are refused with 400.
#[test]
fn new_settings_abandon_a_pass_that_would_take_hours() {
    let (_dir, scene) = scene_copy("cornell_box.ron");
    let srv = serve(&scene, "4");
    srv.wait_state("the first image", finished);
    let r = srv.post(
        "/settings",
        "application/json",
        r#"{"integrator": "fixed-depth", "params": {"depth": "16", "branching": "1024"}}"#,
    );
    assert_eq!(r.status, 400, "{}", r.text());
    assert!(r.text().contains("rays per camera sample"), "{}", r.text());
    let r = srv.post(
        "/settings",
        "application/json",
        r#"{"integrator": "fixed-depth", "params": {"depth": "5", "branching": "64"}}"#,
    );
    assert_eq!(r.status, 200, "{}", r.text());
    srv.wait_state("the long pass", |s| {
        s["render"]["integrator"] == "fixed-depth" && s["render"]["state"] == "rendering"
    });
    let r = srv.post(
        "/settings",
        "application/json",
        r#"{"integrator": "whitted"}"#,
    );
    assert_eq!(r.status, 200, "{}", r.text());
    srv.wait_state("whitted's image", |s| {
        finished(s) && s["render"]["integrator"] == "whitted"
    });
    assert_eq!(srv.run.interrupt().code(), Some(0));
}

/// Another site's page cannot change the settings (its Origin is refused, and only an exact
/// JSON content type is taken), and forty tabs long-polling leave the page reachable.
#[test]
fn cross_origin_posts_are_refused_and_long_polls_leave_slots_free() {
    let (_dir, scene) = scene_copy("cornell_box.ron");
    let srv = serve(&scene, "4");
    let s = srv.wait_state("the first image", finished);
    let post = |origin: Option<&str>, content_type: &str| {
        let origin = origin.map_or(String::new(), |o| format!("Origin: {o}\r\n"));
        let body = r#"{"integrator": "whitted"}"#;
        srv.raw(&format!(
            "POST /settings HTTP/1.1\r\nHost: {}\r\n{origin}Content-Type: {content_type}\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{body}",
            srv.addr,
            body.len()
        ))
    };
    assert_eq!(
        post(Some("http://evil.example"), "application/json").status,
        403
    );
    assert_eq!(post(Some("null"), "application/json").status, 403);
    for bad in ["application/jsonp", "application/json-seq", "text/plain"] {
        assert_eq!(post(None, bad).status, 415, "{bad}");
    }
    assert_eq!(srv.state()["selection"]["integrator"], Value::Null);
    let own = format!("http://{}", srv.addr);
    assert_eq!(
        post(Some(&own), "application/json; charset=utf-8").status,
        200
    );

    // Forty long polls on the current version: the page and the image still answer.
    let v = s["version"].as_u64().unwrap() + 1000;
    let polls: Vec<TcpStream> = (0..40)
        .map(|_| {
            let mut c = TcpStream::connect(srv.addr).unwrap();
            write!(
                c,
                "GET /state?since={v} HTTP/1.1\r\nHost: {}\r\nConnection: close\r\n\r\n",
                srv.addr
            )
            .unwrap();
            c
        })
        .collect();
    std::thread::sleep(std::time::Duration::from_millis(200));
    assert_eq!(srv.get("/").status, 200);
    assert_eq!(srv.get("/settings").status, 200);
    drop(polls);
    assert_eq!(srv.run.interrupt().code(), Some(0));
}

/// A client that sends an endless header line, too many headers, a huge body or trickles
/// its request gets its error status and is cut off; the server keeps answering others.
#[test]
fn oversized_and_slow_requests_are_cut_off() {
    let (_dir, scene) = scene_copy("cornell_box.ron");
    let srv = serve(&scene, "4");
    srv.wait_state("the first image", finished);
    let status_of = |reply: &[u8]| -> u16 {
        let text = String::from_utf8_lossy(reply);
        text.split_whitespace()
            .nth(1)
            .and_then(|s| s.parse().ok())
            .unwrap_or(0)
    };
    // A 200 MB header line, sent until the server stops reading.
    let mut c = TcpStream::connect(srv.addr).unwrap();
    c.set_read_timeout(Some(TIMEOUT)).unwrap();
    c.write_all(b"GET /state HTTP/1.1\r\nX-Long: ").unwrap();
    let chunk = vec![b'a'; 64 * 1024];
    let mut sent = 0usize;
    while sent < 200 << 20 && c.write_all(&chunk).is_ok() {
        sent += chunk.len();
    }
    assert!(
        sent < 10 << 20,
        "the server read {sent} bytes of one header"
    );
    let mut reply = Vec::new();
    let _ = c.read_to_end(&mut reply);
    assert!(
        reply.is_empty() || status_of(&reply) == 431,
        "{}",
        String::from_utf8_lossy(&reply)
    );

    // Too many headers; a body larger than any setting.
    let many: String = (0..100).map(|i| format!("X-{i}: 1\r\n")).collect();
    let r = srv.raw(&format!(
        "GET /state HTTP/1.1\r\nHost: {}\r\n{many}\r\n",
        srv.addr
    ));
    assert_eq!(r.status, 431);
    let r = srv.raw(&format!(
        "POST /settings HTTP/1.1\r\nHost: {}\r\nContent-Type: application/json\r\nContent-Length: 100000000\r\n\r\n{{",
        srv.addr
    ));
    assert_eq!(r.status, 413);

    // A client that sends half a request and waits: 408 within the server's deadline.
    let mut slow = TcpStream::connect(srv.addr).unwrap();
    slow.set_read_timeout(Some(TIMEOUT)).unwrap();
    slow.write_all(b"GET /state HTTP/1.1\r\nHo").unwrap();
    let start = std::time::Instant::now();
    let mut reply = Vec::new();
    let _ = slow.read_to_end(&mut reply);
    assert_eq!(
        status_of(&reply),
        408,
        "{}",
        String::from_utf8_lossy(&reply)
    );
    assert!(start.elapsed() < std::time::Duration::from_secs(10));

    // And the page still answers.
    assert_eq!(srv.get("/").status, 200);
    assert_eq!(srv.run.interrupt().code(), Some(0));
}
