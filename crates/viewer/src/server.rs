//! The web side: an axum router serving the page, the scene once, and the live state over a
//! WebSocket at display rate; page messages drive the device pose and the recorder.
//!
//! Routes:
//! - `GET /` — the page; `GET /app.js`, `GET /style.css` — its code (compiled into the binary);
//! - `GET /vendor/three/three.module.js`, `GET /vendor/three/three.core.js` — three.js, vendored
//!   in crates/viewer/web/vendor/three and compiled into the binary, so nothing is installed;
//! - `GET /api/scene` — meshes (JSON, flat arrays, mm), sent once;
//! - `GET /api/state` — the latest [`FrameState`] (JSON);
//! - `GET /ws` — WebSocket: the server sends `{"type":"state",…}` at display rate; the page
//!   sends `{"type":"pose","q":[x,y,z,gamma,beta,alpha]}`, `{"type":"release"}`,
//!   `{"type":"reset"}`, `{"type":"contacts","on":bool}`, `{"type":"record","on":bool}`.

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{Path as UrlPath, State};
use axum::http::{header, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::Router;
use collide::Pose;
use serde::{Deserialize, Serialize};

use crate::error::ViewerError;
use crate::haptic::HapticLoop;
use crate::hub::InputSource;
use crate::sim::{FrameState, NamedMesh, SceneGeometry};

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
    /// State stream rate (Hz), ~60.
    pub display_hz: f64,
    /// Where recordings started from the page are written.
    pub record_dir: PathBuf,
}

impl Default for WebParams {
    fn default() -> Self {
        Self {
            display_hz: 60.0,
            record_dir: PathBuf::from("."),
        }
    }
}

struct App {
    haptic: Arc<HapticLoop>,
    scene_json: String,
    params: WebParams,
}

/// Builds the router for a running haptic loop.
pub fn router(haptic: Arc<HapticLoop>, params: WebParams) -> Router {
    let scene_json = scene_json(haptic.scene(), haptic.start_pose());
    let app = Arc::new(App {
        haptic,
        scene_json,
        params,
    });
    Router::new()
        .route("/", get(index))
        .route("/app.js", get(app_js))
        .route("/style.css", get(style_css))
        .route("/vendor/three/{file}", get(three_file))
        .route("/api/scene", get(scene))
        .route("/api/state", get(state))
        .route("/ws", get(ws_upgrade))
        .with_state(app)
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

async fn stream(app: Arc<App>, mut socket: WebSocket) {
    let hz = if app.params.display_hz.is_finite() && app.params.display_hz > 0.0 {
        app.params.display_hz
    } else {
        60.0
    };
    let mut tick = tokio::time::interval(Duration::from_secs_f64(1.0 / hz));
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    let mut contacts = false;
    stream_loop(&app, &mut socket, &mut tick, &mut contacts).await;
    if contacts {
        app.haptic.input().want_contacts(false);
    }
    // A closed page lets go of the tool (no-op if another source drives it).
    app.haptic.input().release(InputSource::Page);
}

async fn stream_loop(
    app: &App,
    socket: &mut WebSocket,
    tick: &mut tokio::time::Interval,
    contacts: &mut bool,
) {
    let mut snapshot = FrameState::default();
    loop {
        tokio::select! {
            _ = tick.tick() => {
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
                    Ok(m) => handle(app, m, contacts),
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

fn handle(app: &App, m: PageMsg, contacts: &mut bool) -> Option<Message> {
    let h = &app.haptic;
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
        PageMsg::Reset => {
            h.input().release(InputSource::Page);
            h.input().request_reset();
            None
        }
        PageMsg::Contacts { on } => {
            if on != *contacts {
                h.input().want_contacts(on);
            }
            *contacts = on;
            None
        }
        PageMsg::Record { on: true } => {
            let path = recording_path(&app.params.record_dir);
            Some(match h.start_recording(&path) {
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
