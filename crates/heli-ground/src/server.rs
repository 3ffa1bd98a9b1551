//! The ground station's I/O: a UDP socket to the vehicle and the display's web server.
//!
//! - `GET /` and the page's files, embedded in the binary from `web/` (nothing is fetched
//!   from elsewhere, at build or run time);
//! - `GET /ws`, a WebSocket per page: the station's [`crate::view::View`] as JSON ten times a
//!   second, and the operator's requests ([`crate::station::Request`]) answered one by one.
//!
//! The station ([`Station`]) does the work; this module only moves bytes, keeps the time and
//! saves transferred logs.

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use axum::Router;
use axum::extract::State;
use axum::extract::ws::{Message as WsMessage, WebSocket, WebSocketUpgrade};
use axum::http::Uri;
use axum::response::Response;
use axum::routing::get;
use include_dir::{Dir, include_dir};
use tokio::net::UdpSocket;
use tokio::sync::broadcast;

use heli_web::gate::Role;

use crate::datagrams::Datagrams;
use crate::station::{Output, Station, StationConfig};

/// The page's files.
static WEB: Dir<'_> = include_dir!("$CARGO_MANIFEST_DIR/web");

/// The display's site: its page, then the files all pages share.
static SITE: heli_web::Site = heli_web::Site {
    own: &WEB,
    name: "ground station",
};

/// How often the station steps (commands, transfer, heartbeat).
const TICK: Duration = Duration::from_millis(20);
/// How often the pages get the view.
const VIEW_EVERY_TICKS: u32 = 5;

/// Where the ground station talks and serves.
#[derive(Clone, Debug)]
pub struct ServerConfig {
    /// The vehicle's link address.
    pub vehicle: SocketAddr,
    /// Where the display is served.
    pub http: SocketAddr,
    /// Host names besides IP addresses and `localhost` the display may be reached by
    /// (`heli_web::gate`).
    pub allow_hosts: Vec<String>,
    /// The station.
    pub station: StationConfig,
}

type Shared = Arc<Mutex<Station>>;

#[derive(Clone)]
struct AppState {
    station: Shared,
    views: broadcast::Sender<Arc<str>>,
    /// Frames to the vehicle, queued in the order they were signed (under the station's
    /// lock) and sent by one task: a signed frame sent after a newer one of the same stream
    /// would be refused by the vehicle as a replay.
    frames: Frames,
}

type Frames = tokio::sync::mpsc::UnboundedSender<Vec<u8>>;

/// Longest a request may be (bytes): a request is a few hundred bytes of JSON.
const MAX_REQUEST_BYTES: usize = 4096;
/// How often a page is pinged, and how long it may stay silent before it is dropped (its
/// control token freed): a tablet gone out of Wi-Fi range must not keep the token.
const PING_EVERY: Duration = Duration::from_secs(2);
const PAGE_SILENT_AFTER: Duration = Duration::from_secs(8);

/// Microseconds since the Unix epoch (the link's signing needs the wall clock).
fn unix_us() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| u64::try_from(d.as_micros()).unwrap_or(u64::MAX))
        .unwrap_or(0)
}

/// The ground station could not be served: what it was doing, and why.
#[derive(Debug)]
pub struct ServerError {
    /// What failed (`opening a UDP socket`, `serving the display on 0.0.0.0:8080`).
    pub doing: String,
    /// Why.
    pub source: std::io::Error,
}

impl std::fmt::Display for ServerError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.doing, self.source)
    }
}

impl std::error::Error for ServerError {}

/// An I/O error while `doing` as a [`ServerError`].
fn failed(doing: impl Into<String>) -> impl FnOnce(std::io::Error) -> ServerError {
    let doing = doing.into();
    move |source| ServerError { doing, source }
}

/// What the network did with the link's datagrams, shared by the tasks that send and receive.
type Said = Arc<Mutex<Datagrams>>;

fn lock(station: &Shared) -> std::sync::MutexGuard<'_, Station> {
    station.lock().unwrap_or_else(PoisonError::into_inner)
}

/// Where the display is served, once it is.
#[derive(Clone, Debug)]
pub struct Served {
    /// The bound address.
    pub addr: SocketAddr,
    /// The operator's address, with the key (`heli_web::gate`).
    pub operator_url: String,
    /// An observer's address, with the observer's key (watch only).
    pub observer_url: String,
}

/// Runs the ground station until Ctrl-C or SIGTERM; `ready` is told where the display is
/// served once it is.
pub fn run(config: ServerConfig, ready: impl FnOnce(Served)) -> Result<(), ServerError> {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(failed("starting the ground's runtime"))?;
    rt.block_on(serve(config, ready))
}

async fn serve(config: ServerConfig, ready: impl FnOnce(Served)) -> Result<(), ServerError> {
    let bind: SocketAddr = if config.vehicle.is_ipv4() {
        SocketAddr::from(([0, 0, 0, 0], 0))
    } else {
        SocketAddr::from(([0u16; 8], 0))
    };
    let udp = UdpSocket::bind(bind)
        .await
        .map_err(failed("opening a UDP socket"))?;
    udp.connect(config.vehicle)
        .await
        .map_err(failed(format!("link udp:{}", config.vehicle)))?;
    let udp = Arc::new(udp);
    let listener = tokio::net::TcpListener::bind(config.http)
        .await
        .map_err(failed(format!("serving the display on {}", config.http)))?;
    let addr = listener
        .local_addr()
        .map_err(failed("serving the display"))?;
    let gate = heli_web::gate::Gate::new("ground", addr.port(), config.allow_hosts.clone())
        .map_err(|e| ServerError {
            doing: "guarding the display".into(),
            source: std::io::Error::other(e.to_string()),
        })?;
    let served = Served {
        addr,
        operator_url: gate.operator_url(addr),
        observer_url: gate.observer_url(addr),
    };
    let station: Shared = Arc::new(Mutex::new(Station::new(config.station)));
    let (views, _) = broadcast::channel(16);
    let (frames, outgoing) = tokio::sync::mpsc::unbounded_channel::<Vec<u8>>();
    let state = AppState {
        station: Arc::clone(&station),
        views: views.clone(),
        frames: frames.clone(),
    };
    // One account for both tasks: the system hands a refusal to whichever call comes next.
    let said: Said = Arc::new(Mutex::new(Datagrams::new(config.vehicle)));
    tokio::spawn(receive(
        Arc::clone(&udp),
        Arc::clone(&station),
        Arc::clone(&said),
    ));
    tokio::spawn(send(Arc::clone(&udp), outgoing, Arc::clone(&station), said));
    tokio::spawn(step(frames, Arc::clone(&station), views));
    let app = Router::new()
        .route("/ws", get(ws))
        .fallback(asset)
        .with_state(state)
        .layer(axum::middleware::from_fn_with_state(
            Arc::new(gate),
            heli_web::gate::guard,
        ));
    ready(served);
    axum::serve(listener, app)
        .with_graceful_shutdown(shutdown())
        .await
        .map_err(failed("the display's server"))
}

async fn shutdown() {
    #[cfg(unix)]
    {
        let term = async {
            if let Ok(mut s) =
                tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate())
            {
                s.recv().await;
            } else {
                std::future::pending::<()>().await;
            }
        };
        tokio::select! {
            _ = tokio::signal::ctrl_c() => {}
            () = term => {}
        }
    }
    #[cfg(not(unix))]
    let _ = tokio::signal::ctrl_c().await;
}

/// Datagrams from the vehicle into the station. A receive that fails (nothing listening
/// at the vehicle's address yet: ICMP refused) is said once, and again when one comes.
async fn receive(udp: Arc<UdpSocket>, station: Shared, said: Said) {
    let mut buf = vec![0u8; 65_536];
    loop {
        let outcome = udp.recv(&mut buf).await;
        say(&said, &station, |d| d.received(&outcome));
        match outcome {
            Ok(n) => lock(&station).receive(buf.get(..n).unwrap_or(&[]), unix_us()),
            Err(_) => tokio::time::sleep(TICK).await,
        }
    }
}

/// Frames to the vehicle, in the order they were queued. A send that fails is said once,
/// and again when one goes out.
async fn send(
    udp: Arc<UdpSocket>,
    mut outgoing: tokio::sync::mpsc::UnboundedReceiver<Vec<u8>>,
    station: Shared,
    said: Said,
) {
    while let Some(frame) = outgoing.recv().await {
        let outcome = udp.send(&frame).await;
        say(&said, &station, |d| d.sent(&outcome));
    }
}

/// Puts in the message area what the account of the datagrams has to say of an outcome.
fn say(
    said: &Said,
    station: &Shared,
    of: impl FnOnce(&mut Datagrams) -> Option<crate::datagrams::Said>,
) {
    let note = of(&mut said.lock().unwrap_or_else(PoisonError::into_inner));
    if let Some((severity, text)) = note {
        lock(station).note(severity, text);
    }
}

/// The station's steps, its frames queued, its logs saved, the view to every page.
async fn step(frames: Frames, station: Shared, views: broadcast::Sender<Arc<str>>) {
    let (files, to_write) = tokio::sync::mpsc::unbounded_channel();
    tokio::spawn(write_files(to_write, Arc::clone(&station)));
    let mut ticker = tokio::time::interval(TICK);
    ticker.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut n: u32 = 0;
    loop {
        ticker.tick().await;
        let now = unix_us();
        let (saves, writes, view) = {
            let mut s = lock(&station);
            let mut saves = Vec::new();
            let mut writes = Vec::new();
            for out in s.tick(now) {
                match out {
                    // Queued under the lock: in signing order.
                    Output::Send(frame) => {
                        let _ = frames.send(frame);
                    }
                    Output::Save(path, bytes) => saves.push((path, bytes)),
                    Output::Write(path, bytes) => writes.push((path, bytes)),
                }
            }
            n = n.wrapping_add(1);
            let view = n.is_multiple_of(VIEW_EVERY_TICKS).then(|| s.view(now));
            (saves, writes, view)
        };
        for write in writes {
            // To the writer task: in order, outside the station's lock, and never holding
            // the steps up (a storage that hangs must not stop the heartbeats).
            let _ = files.send(write);
        }
        for (path, bytes) in saves {
            let station = Arc::clone(&station);
            tokio::task::spawn_blocking(move || {
                let result = crate::transfer::save_new(&path, &bytes);
                lock(&station).saved(&path, result);
            });
        }
        if let Some(view) = view
            && let Ok(json) =
                serde_json::to_string(&serde_json::json!({"type": "view", "view": view}))
        {
            let _ = views.send(Arc::from(json));
        }
    }
}

/// Writes the station's files (the packs' totals) in the order they come, each whole, off the
/// runtime's threads; a write that fails, or whose directory cannot be synced, is said.
async fn write_files(
    mut to_write: tokio::sync::mpsc::UnboundedReceiver<(PathBuf, Vec<u8>)>,
    station: Shared,
) {
    while let Some((path, bytes)) = to_write.recv().await {
        let shown = path.display().to_string();
        let said = tokio::task::spawn_blocking(move || match replace(&path, &bytes) {
            Ok(replaced) => replaced.warning().map(|w| ("warning", w)),
            Err(e) => Some(("error", e.to_string())),
        })
        .await
        .unwrap_or_else(|e| Some(("error", format!("the writer stopped: {e}"))));
        if let Some((severity, text)) = said {
            lock(&station).note(severity, format!("{shown}: {text}"));
        }
    }
}

/// Writes `bytes` over the file at `path` whole (a temporary file beside it, synced,
/// renamed over it): a crash of the ground computer leaves the old totals or the new ones.
fn replace(path: &Path, bytes: &[u8]) -> std::io::Result<heli_log::replace::Replaced> {
    let name = path
        .file_name()
        .map_or_else(|| "file".to_string(), |n| n.to_string_lossy().to_string());
    heli_log::replace::replace_file(path, &path.with_file_name(format!(".{name}.tmp")), bytes)
}

/// The display's files (its own, then the shared ones).
async fn asset(uri: Uri) -> Response {
    SITE.file(&uri)
}

/// A page's WebSocket: the gate (`heli_web::gate::guard`) let it through with its role.
async fn ws(
    upgrade: WebSocketUpgrade,
    axum::Extension(role): axum::Extension<Role>,
    State(state): State<AppState>,
) -> Response {
    upgrade
        .max_message_size(MAX_REQUEST_BYTES)
        .max_frame_size(MAX_REQUEST_BYTES)
        .on_upgrade(move |socket| page(socket, state, role))
}

/// One page: the views out, its requests in.
async fn page(mut socket: WebSocket, state: AppState, role: Role) {
    let id = match role {
        Role::Operator => lock(&state.station).join(),
        Role::Observer => lock(&state.station).join_observer(),
    };
    let mut views = state.views.subscribe();
    let hello = serde_json::json!({"type": "hello", "client": id}).to_string();
    // A page opened late gets every message kept (each warning and worse of the session),
    // not only the newest the views carry.
    let history = serde_json::json!({
        "type": "history",
        "messages": lock(&state.station).message_history(),
    })
    .to_string();
    for text in [hello, history] {
        if socket.send(WsMessage::Text(text.into())).await.is_err() {
            lock(&state.station).leave(id);
            return;
        }
    }
    let mut ping = tokio::time::interval(PING_EVERY);
    let mut heard = tokio::time::Instant::now();
    loop {
        tokio::select! {
            _ = ping.tick() => {
                if heard.elapsed() > PAGE_SILENT_AFTER
                    || socket.send(WsMessage::Ping(Vec::new().into())).await.is_err()
                {
                    break;
                }
            }
            view = views.recv() => match view {
                Ok(json) => {
                    if socket.send(WsMessage::Text(json.as_ref().into())).await.is_err() {
                        break;
                    }
                }
                Err(broadcast::error::RecvError::Lagged(_)) => {}
                Err(broadcast::error::RecvError::Closed) => break,
            },
            msg = socket.recv() => {
                let Some(Ok(msg)) = msg else {
                    break;
                };
                heard = tokio::time::Instant::now();
                let reply = match msg {
                    WsMessage::Text(text) => request(&state, id, text.as_str()).await,
                    WsMessage::Binary(_) => serde_json::json!({"type": "reply", "ok": false,
                        "text": "binary messages are not requests"})
                    .to_string(),
                    _ => continue,
                };
                if socket.send(WsMessage::Text(reply.into())).await.is_err() {
                    break;
                }
            }
        }
    }
    lock(&state.station).leave(id);
}

/// An operator's request: the station's answer, and the frames it made queued at once.
async fn request(state: &AppState, id: u64, text: &str) -> String {
    let seq = serde_json::from_str::<serde_json::Value>(text)
        .ok()
        .and_then(|v| v.get("seq").and_then(serde_json::Value::as_u64));
    let result = {
        let mut s = lock(&state.station);
        let result = s.request(id, text, unix_us());
        // Queued under the lock: in signing order.
        for frame in s.take_outbox() {
            let _ = state.frames.send(frame);
        }
        result
    };
    let (ok, text) = match result {
        Ok(t) => (true, t),
        Err(t) => (false, t.to_string()),
    };
    serde_json::json!({"type": "reply", "seq": seq, "ok": ok, "text": text}).to_string()
}
