//! The web side: an axum router serving the page, the scene once, and the live state over a
//! WebSocket at display rate; page messages drive the device pose and the recorder.
//!
//! Routes:
//! - `GET /` — the page; `GET /app.js`, `GET /style.css` — its code (compiled into the binary);
//! - `GET /vendor/three/three.module.js`, `GET /vendor/three/three.core.js` — three.js, vendored
//!   in crates/viewer/web/vendor/three and compiled into the binary, so nothing is installed;
//! - `GET /api/scene` — meshes (JSON, flat arrays, mm), sent once;
//! - `GET /api/state` — the latest [`FrameState`] (JSON);
//! - `GET /ws` — WebSocket: the server sends `{"type":"state",…}` at display rate and
//!   `{"type":"role",…}` whenever the page's role changes; the page sends
//!   `{"type":"pose","q":[x,y,z,gamma,beta,alpha]}`, `{"type":"release"}`,
//!   `{"type":"reset"}`, `{"type":"contacts","on":bool}`, `{"type":"record","on":bool}`,
//!   `{"type":"friction","on":bool}`.
//!
//! Security (docs/VIEWER.md): every request's `Host` and `Origin` are checked
//! ([`crate::guard`]; refused with 403), one page owns the device at a time
//! ([`crate::pages`]), and recording from the page is off unless
//! [`WebParams::allow_page_recording`].

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{Path as UrlPath, Request, State};
use axum::http::{header, HeaderMap, StatusCode};
use axum::middleware::{self, Next};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::Router;
use collide::Pose;
use serde::{Deserialize, Serialize};

use crate::error::ViewerError;
use crate::guard::AccessPolicy;
use crate::haptic::HapticLoop;
use crate::hub::InputSource;
use crate::pages::{PageSeats, Role};
use crate::simulation::{FrameState, NamedMesh, SceneGeometry};

const INDEX_HTML: &str = include_str!("../web/index.html");
const APP_JS: &str = include_str!("../web/app.js");
const STYLE_CSS: &str = include_str!("../web/style.css");
/// three.js (see crates/viewer/web/vendor/three/README.md): the module the page imports and the
/// core it imports in turn, served from the binary so a fresh clone needs no `npm ci`.
const THREE_FILES: [(&str, &str); 2] = [
    (
        "three.module.js",
        include_str!("../web/vendor/three/three.module.js"),
    ),
    (
        "three.core.js",
        include_str!("../web/vendor/three/three.core.js"),
    ),
];

/// Web server settings.
#[derive(Clone, Debug)]
pub struct WebParams {
    /// State stream rate (Hz), [`WebParams::MIN_DISPLAY_HZ`] ..= [`WebParams::MAX_DISPLAY_HZ`].
    pub display_hz: f64,
    /// Where recordings started from the page are written.
    pub record_dir: PathBuf,
    /// The address the server listens on (after binding, so port 0 is resolved): `Host` and
    /// `Origin` must name it ([`crate::guard`]).
    pub addr: SocketAddr,
    /// Further origins allowed to use the server (`http(s)://host[:port]`, `--allow-origin`).
    pub allowed_origins: Vec<String>,
    /// Whether the page may start recordings (`--allow-page-recording`); off by default, the
    /// server then ignores the page's record commands.
    pub allow_page_recording: bool,
}

impl Default for WebParams {
    fn default() -> Self {
        Self {
            display_hz: 60.0,
            record_dir: PathBuf::from("."),
            addr: SocketAddr::from(([127, 0, 0, 1], 8080)),
            allowed_origins: Vec::new(),
            allow_page_recording: false,
        }
    }
}

impl WebParams {
    /// Lowest state stream rate (Hz).
    pub const MIN_DISPLAY_HZ: f64 = 1.0;
    /// Highest state stream rate (Hz): no display refreshes faster.
    pub const MAX_DISPLAY_HZ: f64 = 240.0;

    /// Checks the settings; the error names the CLI flag and what is wrong.
    pub fn validate(&self) -> Result<(), ViewerError> {
        if !(self.display_hz.is_finite()
            && (Self::MIN_DISPLAY_HZ..=Self::MAX_DISPLAY_HZ).contains(&self.display_hz))
        {
            return Err(ViewerError::Params(format!(
                "--display-hz must be between {} and {} Hz, got {}",
                Self::MIN_DISPLAY_HZ,
                Self::MAX_DISPLAY_HZ,
                crate::error::show_number(self.display_hz)
            )));
        }
        if self.allow_page_recording && !self.record_dir.is_dir() {
            return Err(ViewerError::Params(format!(
                "--record-dir {} is not a directory",
                self.record_dir.display()
            )));
        }
        AccessPolicy::new(self.addr, &self.allowed_origins)?;
        Ok(())
    }

    /// The stream period, from the (clamped) display rate.
    fn display_period(&self) -> Duration {
        let hz = if self.display_hz.is_finite() {
            self.display_hz
                .clamp(Self::MIN_DISPLAY_HZ, Self::MAX_DISPLAY_HZ)
        } else {
            60.0
        };
        Duration::from_secs_f64(1.0 / hz)
    }
}

struct App {
    haptic: Arc<HapticLoop>,
    scene_json: String,
    params: WebParams,
    policy: AccessPolicy,
    seats: PageSeats,
}

/// Builds the router for a running haptic loop; fails when `params` are invalid
/// ([`WebParams::validate`]).
pub fn router(haptic: Arc<HapticLoop>, params: WebParams) -> Result<Router, ViewerError> {
    params.validate()?;
    let scene_json = scene_json(haptic.scene(), haptic.start_pose());
    let policy = AccessPolicy::new(params.addr, &params.allowed_origins)?;
    let app = Arc::new(App {
        haptic,
        scene_json,
        params,
        policy,
        seats: PageSeats::new(),
    });
    Ok(Router::new()
        .route("/", get(index))
        .route("/app.js", get(app_js))
        .route("/style.css", get(style_css))
        .route("/vendor/three/{file}", get(three_file))
        .route("/api/scene", get(scene))
        .route("/api/state", get(state))
        .route("/ws", get(ws_upgrade))
        .layer(middleware::from_fn_with_state(app.clone(), check_access))
        .with_state(app))
}

/// Refuses (403) a request whose `Host` or `Origin` is not this server's ([`crate::guard`]).
async fn check_access(State(app): State<Arc<App>>, req: Request, next: Next) -> Response {
    let verdict = header_str(req.headers(), header::HOST).and_then(|host| {
        let origin = header_str(req.headers(), header::ORIGIN)?;
        app.policy.check(host, origin).map_err(|r| r.to_string())
    });
    match verdict {
        Ok(()) => next.run(req).await,
        Err(why) => (StatusCode::FORBIDDEN, why).into_response(),
    }
}

/// A header's value; `Ok(None)` when absent, an error when present but not visible ASCII.
fn header_str(h: &HeaderMap, name: header::HeaderName) -> Result<Option<&str>, String> {
    match h.get(&name) {
        None => Ok(None),
        Some(v) => v
            .to_str()
            .map(Some)
            .map_err(|_| format!("unreadable {name} header")),
    }
}

/// Binds `addr` for the web server.
pub async fn bind(addr: SocketAddr) -> Result<tokio::net::TcpListener, ViewerError> {
    tokio::net::TcpListener::bind(addr)
        .await
        .map_err(|source| ViewerError::Bind {
            what: "web server",
            addr: addr.to_string(),
            source,
        })
}

/// Serves `router` on `listener` until `shutdown` completes.
pub async fn run(
    listener: tokio::net::TcpListener,
    router: Router,
    shutdown: impl std::future::Future<Output = ()> + Send + 'static,
) -> Result<(), ViewerError> {
    axum::serve(listener, router)
        .with_graceful_shutdown(shutdown)
        .await
        .map_err(ViewerError::Serve)
}

async fn index() -> impl IntoResponse {
    (
        [(header::CONTENT_TYPE, "text/html; charset=utf-8")],
        INDEX_HTML,
    )
}

async fn app_js() -> impl IntoResponse {
    (
        [(header::CONTENT_TYPE, "text/javascript; charset=utf-8")],
        APP_JS,
    )
}

async fn style_css() -> impl IntoResponse {
    (
        [(header::CONTENT_TYPE, "text/css; charset=utf-8")],
        STYLE_CSS,
    )
}

async fn three_file(UrlPath(file): UrlPath<String>) -> Response {
    // Only the vendored files, by exact name: nothing from the file system is ever served.
    match THREE_FILES.iter().find(|(name, _)| *name == file) {
        Some((_, body)) => (
            [
                (header::CONTENT_TYPE, "text/javascript; charset=utf-8"),
                (header::CACHE_CONTROL, "max-age=3600"),
            ],
            *body,
        )
            .into_response(),
        None => (StatusCode::NOT_FOUND, "no such file").into_response(),
    }
}

async fn scene(State(app): State<Arc<App>>) -> impl IntoResponse {
    (
        [(header::CONTENT_TYPE, "application/json")],
        app.scene_json.clone(),
    )
}

async fn state(State(app): State<Arc<App>>) -> Response {
    let s = app.haptic.state().latest();
    match serde_json::to_string(&StateMsg::new(&s)) {
        Ok(body) => ([(header::CONTENT_TYPE, "application/json")], body).into_response(),
        Err(e) => (StatusCode::INTERNAL_SERVER_ERROR, e.to_string()).into_response(),
    }
}

/// A mesh as the page wants it: flat arrays.
#[derive(Serialize)]
struct MeshJson<'a> {
    name: &'a str,
    /// Fixed world pose (mm, rad).
    pose: [f64; 6],
    /// x0,y0,z0,x1,… (mm, rounded to µm).
    positions: Vec<f32>,
    /// a0,b0,c0,a1,…
    indices: Vec<u32>,
}

impl<'a> MeshJson<'a> {
    fn new(m: &'a NamedMesh) -> Self {
        Self {
            name: &m.name,
            pose: m.pose,
            positions: m
                .mesh
                .vertices
                .iter()
                .flat_map(|v| v.iter().map(|&c| c as f32))
                .collect(),
            indices: m.mesh.triangles.iter().flatten().copied().collect(),
        }
    }
}

#[derive(Serialize)]
struct SceneJson<'a> {
    name: &'a str,
    tool: MeshJson<'a>,
    objects: Vec<MeshJson<'a>>,
    start: [f64; 6],
    kt: f64,
    kr: f64,
    max_force: f64,
    friction: bool,
}

fn scene_json(s: &SceneGeometry, start: Pose) -> String {
    let j = SceneJson {
        name: &s.name,
        tool: MeshJson::new(&s.tool),
        objects: s.objects.iter().map(MeshJson::new).collect(),
        start: start.to_array(),
        kt: s.kt,
        kr: s.kr,
        max_force: s.max_force,
        friction: s.friction,
    };
    serde_json::to_string(&j).unwrap_or_else(|e| format!("{{\"error\":\"{e}\"}}"))
}

#[derive(Serialize)]
struct StateMsg<'a> {
    #[serde(rename = "type")]
    kind: &'static str,
    #[serde(flatten)]
    state: &'a FrameState,
}

impl<'a> StateMsg<'a> {
    fn new(state: &'a FrameState) -> Self {
        Self {
            kind: "state",
            state,
        }
    }
}

/// What the page sends.
#[derive(Deserialize, Debug)]
#[serde(tag = "type", rename_all = "lowercase")]
enum PageMsg {
    Pose { q: [f64; 6] },
    Release,
    Reset,
    Contacts { on: bool },
    Record { on: bool },
    Friction { on: bool },
}

async fn ws_upgrade(State(app): State<Arc<App>>, ws: WebSocketUpgrade) -> Response {
    ws.on_upgrade(move |socket| stream(app, socket))
}

fn notice(kind: &str, text: &str) -> Message {
    Message::Text(
        serde_json::json!({ "type": kind, "message": text })
            .to_string()
            .into(),
    )
}

/// The page's role as told to it: the owner of its seat drives the tool unless a physical
/// device (the UDP bridge, the device bridge) drives it; then every page watches.
fn role_msg(app: &App, id: u64, device_drives: bool) -> Message {
    let (role, ahead) = match app.seats.role(id) {
        Role::Owner if !device_drives => ("owner", 0),
        Role::Owner => ("watcher", 0),
        Role::Watcher { ahead } => ("watcher", ahead),
    };
    Message::Text(
        serde_json::json!({
            "type": "role",
            "role": role,
            "ahead": ahead,
            "device": device_drives,
            "page_recording": app.params.allow_page_recording,
        })
        .to_string()
        .into(),
    )
}

async fn stream(app: Arc<App>, mut socket: WebSocket) {
    let mut tick = tokio::time::interval(app.params.display_period());
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    let mut contacts = false;
    let mut seat_changes = app.seats.subscribe();
    let id = app.seats.join();
    stream_loop(
        &app,
        id,
        &mut socket,
        &mut tick,
        &mut seat_changes,
        &mut contacts,
    )
    .await;
    if contacts {
        app.haptic.input().want_contacts(false);
    }
    // The owner closing lets go of the tool (no-op if another source drives it); a watcher
    // closing changes nothing.
    if app.seats.leave(id) {
        app.haptic.input().release(InputSource::Page);
    }
}

async fn stream_loop(
    app: &App,
    id: u64,
    socket: &mut WebSocket,
    tick: &mut tokio::time::Interval,
    seat_changes: &mut tokio::sync::watch::Receiver<u64>,
    contacts: &mut bool,
) {
    let mut snapshot = FrameState::default();
    seat_changes.mark_unchanged();
    let mut device_drives = app.haptic.input().device_drives();
    if socket.send(role_msg(app, id, device_drives)).await.is_err() {
        return;
    }
    loop {
        tokio::select! {
            changed = seat_changes.changed() => {
                if changed.is_err()
                    || socket.send(role_msg(app, id, device_drives)).await.is_err()
                {
                    return;
                }
            }
            _ = tick.tick() => {
                // A device taking over or letting go changes every page's role.
                let now_drives = app.haptic.input().device_drives();
                if now_drives != device_drives {
                    device_drives = now_drives;
                    if socket.send(role_msg(app, id, device_drives)).await.is_err() {
                        return;
                    }
                }
                app.haptic.state().with_latest(|s| snapshot.copy_from(s));
                if !*contacts {
                    snapshot.contacts.clear();
                }
                let text = match serde_json::to_string(&StateMsg::new(&snapshot)) {
                    Ok(t) => t,
                    Err(_) => continue,
                };
                if socket.send(Message::Text(text.into())).await.is_err() {
                    return;
                }
            }
            msg = socket.recv() => {
                let Some(Ok(msg)) = msg else { return };
                let Message::Text(text) = msg else { continue };
                let reply = match serde_json::from_str::<PageMsg>(text.as_str()) {
                    Ok(m) => handle(app, id, m, contacts),
                    Err(e) => Some(notice("error", &format!("bad message: {e}"))),
                };
                if let Some(r) = reply {
                    if socket.send(r).await.is_err() {
                        return;
                    }
                }
            }
        }
    }
}

fn handle(app: &App, id: u64, m: PageMsg, contacts: &mut bool) -> Option<Message> {
    let h = &app.haptic;
    let device_drives = h.input().device_drives();
    if !app.seats.is_owner(id) || device_drives {
        return match m {
            // Display only: any page may ask for the contact list.
            PageMsg::Contacts { on } => {
                if on != *contacts {
                    h.input().want_contacts(on);
                }
                *contacts = on;
                None
            }
            // A watcher's poses are dropped without a word (they may come at display rate).
            PageMsg::Pose { .. } => None,
            _ if device_drives => Some(notice(
                "error",
                "ignored: a device drives the tool (the page watches while it does)",
            )),
            _ => Some(notice(
                "error",
                "ignored: another page controls the device (this one watches until it closes)",
            )),
        };
    }
    match m {
        PageMsg::Pose { q } => match h
            .input()
            .submit(InputSource::Page, Pose::from_array(q), None)
        {
            Ok(_) => None,
            Err(e) => Some(notice("error", &format!("pose not applied: {e:?}"))),
        },
        PageMsg::Release => {
            h.input().release(InputSource::Page);
            None
        }
        // Checked again under the hub's lock: a device may have taken over since.
        PageMsg::Reset => match h.input().request_reset(InputSource::Page) {
            Ok(()) => None,
            Err(e) => Some(notice("error", &format!("reset not applied: {e:?}"))),
        },
        PageMsg::Contacts { on } => {
            if on != *contacts {
                h.input().want_contacts(on);
            }
            *contacts = on;
            None
        }
        PageMsg::Friction { on } => {
            h.input().set_friction(on);
            None
        }
        PageMsg::Record { .. } if !app.params.allow_page_recording => Some(notice(
            "error",
            "recording from the page is off (start serve with --allow-page-recording)",
        )),
        PageMsg::Record { on: true } => {
            let path = recording_path(&app.params.record_dir);
            Some(match h.start_recording(&path, false) {
                Ok(()) => notice("recording", &format!("recording to {}", path.display())),
                Err(e) => notice("error", &e.to_string()),
            })
        }
        PageMsg::Record { on: false } => Some(match h.stop_recording() {
            Ok(s) => notice(
                "recording",
                &format!(
                    "recorded {} frames to {} (replay: haptic6d run SCENE --trajectory {})",
                    s.rows,
                    s.path.display(),
                    s.path.display()
                ),
            ),
            Err(e) => notice("error", &e.to_string()),
        }),
    }
}

/// A fresh file name for a recording started from the page: `trajectory-<unix seconds>.csv`.
fn recording_path(dir: &Path) -> PathBuf {
    let secs = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0);
    let mut p = dir.join(format!("trajectory-{secs}.csv"));
    let mut k = 1;
    while p.exists() {
        p = dir.join(format!("trajectory-{secs}-{k}.csv"));
        k += 1;
    }
    p
}
