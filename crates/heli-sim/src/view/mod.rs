//! The HILSim's view of the flying helicopter (`heli hilsim --view ADDR`): a web page that
//! draws the simulator's truth in real 3D (WebGL, three.js vendored in `heli-web`) — the
//! X-Cell 60 as solids at its true size with its rotor disk tilting with the flapping, its
//! shadow on a mown field with the take-off pad and distance rings, sky and horizon, the
//! flight plan, a trail, a wind sock — seen from where the pilot stands (auto-zoom), from a
//! chase camera or from above. It is the truth, labelled so; the ground display (`heli ground
//! --http`) draws the vehicle's estimate and says so.
//!
//! The simulator publishes a frame (JSON) whenever it likes ([`TruthFeed::publish`]); each
//! page gets the setup (the plan, the scenario's name) once and then the newest frame at most
//! 30 times a second, whatever the simulation's speed. The page's files (`web/`) are
//! embedded like the display's, with the instruments all pages share (`heli-web`).
//! [`cockpit`] is the simulator's side: what it publishes, and the pages' transmitter and
//! the trainer's failures taken into the simulation.
//!
//! Served read-only, nothing a page sends reaches the simulator. Served with a control
//! channel (`heli hilsim --pilot`), a page may hold the transmitter — its sticks and
//! switches, a [`Transmitter`], checked here — hand it back, and trigger failures (passed on as
//! the page wrote them, for the simulator to check). What is refused is answered with an
//! `error` message naming why.

use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;

use axum::Router;
use axum::extract::State;
use axum::extract::ws::{Message as WsMessage, WebSocket, WebSocketUpgrade};
use axum::http::Uri;
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use heli_types::Transmitter;
use heli_types::transmitter::OutOfRange;
use heli_web::gate::Role;
use include_dir::{Dir, include_dir};
use tokio::sync::watch;

pub mod cockpit;
pub mod holder;

/// Longest between two frames to a page.
const FRAME_EVERY: Duration = Duration::from_millis(33);

/// What a page sends the simulator.
#[derive(Clone, Debug, PartialEq)]
pub enum ViewInput {
    /// The page holds the transmitter: its sticks and switches now.
    Pilot(Transmitter),
    /// The page takes the transmitter (refused while another page holds it).
    Take,
    /// The page hands the transmitter back to the scenario's pilot.
    Release,
    /// Trigger a failure: the request as the page wrote it (JSON with a `kind`).
    Fault(String),
    /// The page holding the transmitter is gone (not sent by a page).
    Gone,
}

/// Why a page's message is refused.
#[derive(Debug)]
pub enum InputError {
    /// Not JSON at all (the start of the text).
    NotJson(serde_json::Error, String),
    /// A pilot message whose fields are wrong.
    Pilot(serde_json::Error),
    /// A pilot message with a channel out of its range.
    OutOfRange(OutOfRange),
    /// A fault message without its `fault` object.
    NoFault,
    /// A message of no known type.
    UnknownType(String),
}

impl std::fmt::Display for InputError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            InputError::NotJson(e, text) => write!(f, "not JSON ({e}): {text:.80}"),
            InputError::Pilot(e) => write!(f, "pilot message: {e}"),
            InputError::OutOfRange(e) => write!(f, "{e}"),
            InputError::NoFault => write!(f, "fault message: no `fault` object"),
            InputError::UnknownType(t) => {
                write!(
                    f,
                    "unknown message type '{t}' (take, pilot, release, fault)"
                )
            }
        }
    }
}

impl std::error::Error for InputError {}

/// Reads one message from a page: what it asks, or why it is refused.
pub fn parse_input(text: &str) -> Result<ViewInput, InputError> {
    let value: serde_json::Value = serde_json::from_str(text)
        .map_err(|e| InputError::NotJson(e, text.chars().take(80).collect()))?;
    let kind = value.get("type").and_then(|t| t.as_str()).unwrap_or("");
    match kind {
        "pilot" => {
            let mut fields = value.clone();
            if let Some(map) = fields.as_object_mut() {
                map.remove("type");
            }
            let frame: Transmitter = serde_json::from_value(fields).map_err(InputError::Pilot)?;
            frame.check().map_err(InputError::OutOfRange)?;
            Ok(ViewInput::Pilot(frame))
        }
        "take" => Ok(ViewInput::Take),
        "release" => Ok(ViewInput::Release),
        "fault" => match value.get("fault") {
            Some(fault) if fault.is_object() => Ok(ViewInput::Fault(fault.to_string())),
            _ => Err(InputError::NoFault),
        },
        other => Err(InputError::UnknownType(other.to_string())),
    }
}

/// Where the simulator hands its frames to the pages.
#[derive(Clone, Debug)]
pub struct TruthFeed {
    frames: watch::Sender<Arc<str>>,
}

impl TruthFeed {
    /// Makes `frame_json` the newest frame.
    pub fn publish(&self, frame_json: String) {
        self.frames.send_replace(Arc::from(frame_json));
    }
}

#[derive(Clone)]
struct ViewState {
    setup: Arc<str>,
    frames: watch::Receiver<Arc<str>>,
    control: Option<std::sync::mpsc::Sender<ViewInput>>,
    /// Who holds the transmitter.
    holder: holder::Holder,
}

/// Where the view is served: the bound address, and the pilot's and an observer's addresses
/// with their keys (`heli_web::gate`: every page and WebSocket needs one).
#[derive(Clone, Debug)]
pub struct Served {
    /// The bound address.
    pub addr: SocketAddr,
    /// The pilot's (operator's) address: may take the transmitter, trigger failures.
    pub operator_url: String,
    /// An observer's address: watches only.
    pub observer_url: String,
}

/// Serves the view on `addr` from a thread of its own; returns where it is served (port 0
/// picks a free one) and the feed. `setup_json` goes to every page first. With `control`,
/// what pages send goes there ([`ViewInput`]); without, it is refused.
pub fn spawn(
    addr: SocketAddr,
    setup_json: String,
    control: Option<std::sync::mpsc::Sender<ViewInput>>,
) -> std::io::Result<(Served, TruthFeed)> {
    let context = |what: String| {
        move |e: std::io::Error| std::io::Error::new(e.kind(), format!("{what}: {e}"))
    };
    let (frames, rx) = watch::channel(Arc::<str>::from(""));
    let state = ViewState {
        setup: Arc::from(setup_json),
        frames: rx,
        control,
        holder: holder::Holder::default(),
    };
    let (bound_tx, bound_rx) = std::sync::mpsc::channel();
    std::thread::Builder::new()
        .name("truth-view".into())
        .spawn(move || {
            let rt = match tokio::runtime::Builder::new_current_thread()
                .enable_all()
                .build()
            {
                Ok(rt) => rt,
                Err(e) => {
                    let _ = bound_tx.send(Err(context("starting the view's runtime".into())(e)));
                    return;
                }
            };
            rt.block_on(async move {
                let listener = match tokio::net::TcpListener::bind(addr).await {
                    Ok(l) => l,
                    Err(e) => {
                        let _ =
                            bound_tx.send(Err(context(format!("serving the view on {addr}"))(e)));
                        return;
                    }
                };
                let served = listener
                    .local_addr()
                    .map_err(context("serving the view".into()))
                    .and_then(|bound| {
                        heli_web::gate::Gate::new("view", bound.port(), Vec::new())
                            .map(|gate| (bound, gate))
                            .map_err(|e| std::io::Error::other(e.to_string()))
                    });
                let gate = match served {
                    Ok((bound, gate)) => {
                        let _ = bound_tx.send(Ok(Served {
                            addr: bound,
                            operator_url: gate.operator_url(bound),
                            observer_url: gate.observer_url(bound),
                        }));
                        gate
                    }
                    Err(e) => {
                        let _ = bound_tx.send(Err(e));
                        return;
                    }
                };
                let app = Router::new()
                    .route("/", get(page))
                    .route("/ws", get(ws))
                    .fallback(asset)
                    .with_state(state)
                    .layer(axum::middleware::from_fn_with_state(
                        Arc::new(gate),
                        heli_web::gate::guard,
                    ));
                let _ = axum::serve(listener, app).await;
            });
        })
        .map_err(context("starting the view's thread".into()))?;
    let bound = bound_rx
        .recv()
        .map_err(|_| std::io::Error::other("the view's thread ended before serving"))??;
    Ok((bound, TruthFeed { frames }))
}

/// The page's files.
static WEB: Dir<'_> = include_dir!("$CARGO_MANIFEST_DIR/web");

/// The view's site: its page, then the files all pages share.
static SITE: heli_web::Site = heli_web::Site {
    own: &WEB,
    name: "simulator view",
};

async fn page() -> Response {
    SITE.file(&Uri::from_static("/truth.html"))
}

async fn asset(uri: Uri) -> Response {
    SITE.file(&uri)
}

/// A page's WebSocket: the gate (`heli_web::gate::guard`) let it through with its role.
async fn ws(
    upgrade: WebSocketUpgrade,
    axum::Extension(role): axum::Extension<Role>,
    State(state): State<ViewState>,
) -> Response {
    upgrade
        .max_message_size(1024)
        .on_upgrade(move |socket| feed(socket, state, role))
        .into_response()
}

/// The setup, then the newest frame whenever there is a new one, at most every
/// [`FRAME_EVERY`]; what the page sends goes to the control channel, or is refused. Ends
/// when the page goes.
async fn feed(socket: WebSocket, state: ViewState, role: Role) {
    let page = state.holder.join();
    let holder = state.holder.clone();
    let control = state.control.clone();
    feed_page(socket, state, page, role).await;
    // A page gone with the transmitter: nobody holds it; the receiver loses the signal
    // (the cockpit hears no more sticks), as with a transmitter switched off.
    if holder.leave(page)
        && let Some(c) = control
    {
        let _ = c.send(ViewInput::Gone);
    }
}

/// What a page's message does with the transmitter: `Ok(Some(input))` goes to the
/// simulator, `Ok(None)` is done here, `Err` is refused with its words.
fn admit(
    state: &ViewState,
    page: holder::PageId,
    role: Role,
    input: ViewInput,
) -> Result<Option<ViewInput>, String> {
    if role == Role::Observer && matches!(input, ViewInput::Take | ViewInput::Fault(_)) {
        return Err(
            "this page is an observer's (opened with the observer's key): it watches; open the pilot's address to fly or fail things".into(),
        );
    }
    match input {
        ViewInput::Take => state.holder.take(page).map(|()| None),
        ViewInput::Pilot(_) => state.holder.check(page).map(|()| Some(input)),
        ViewInput::Release => state.holder.release(page).map(|()| Some(input)),
        ViewInput::Fault(_) | ViewInput::Gone => Ok(Some(input)),
    }
    .map_err(|e| e.to_string())
}

async fn feed_page(mut socket: WebSocket, mut state: ViewState, page: holder::PageId, role: Role) {
    let setup = WsMessage::Text(state.setup.to_string().into());
    if socket.send(setup).await.is_err() {
        return;
    }
    // Which page this is and who holds the transmitter, sent again whenever it changes.
    let mut told: Option<Option<holder::PageId>> = None;
    let mut tick = tokio::time::interval(FRAME_EVERY);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    loop {
        tokio::select! {
            _ = tick.tick() => {
                let now = state.holder.holder();
                if state.control.is_some() && told != Some(now) {
                    told = Some(now);
                    let msg = serde_json::json!({"type": "transmitter", "you": page, "holder": now});
                    if socket.send(WsMessage::Text(msg.to_string().into())).await.is_err() {
                        return;
                    }
                }
                if !state.frames.has_changed().unwrap_or(false) {
                    continue;
                }
                let frame = state.frames.borrow_and_update().clone();
                if !frame.is_empty()
                    && socket
                        .send(WsMessage::Text(frame.to_string().into()))
                        .await
                        .is_err()
                {
                    return;
                }
            }
            msg = socket.recv() => {
                let text = match msg {
                    Some(Ok(WsMessage::Text(text))) => text,
                    Some(Ok(WsMessage::Close(_))) | Some(Err(_)) | None => return,
                    Some(Ok(_)) => continue,
                };
                let refusal = match (&state.control, parse_input(text.as_str())) {
                    (None, _) => Some(
                        "this view is read-only: start heli hilsim with --pilot to fly".into(),
                    ),
                    (Some(_), Err(e)) => Some(e.to_string()),
                    (Some(control), Ok(input)) => match admit(&state, page, role, input) {
                        Err(why) => Some(why),
                        Ok(None) => None,
                        Ok(Some(input)) => control
                            .send(input)
                            .err()
                            .map(|_| "the simulator has stopped".to_string()),
                    },
                };
                if let Some(message) = refusal {
                    let reply = serde_json::json!({"type": "error", "message": message});
                    if socket
                        .send(WsMessage::Text(reply.to_string().into()))
                        .await
                        .is_err()
                    {
                        return;
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_page_may_send_sticks_a_release_and_failures_and_nothing_else() {
        let frame = r#"{"type":"pilot","aileron":0.5,"elevator":-0.2,"rudder":0,"collective":0.1,"throttle":0.8,"auto":false,"bypass":true}"#;
        match parse_input(frame) {
            Ok(ViewInput::Pilot(p)) => {
                assert_eq!(p.aileron, 0.5);
                assert!(p.bypass && !p.auto);
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(
            parse_input(r#"{"type":"release"}"#).ok(),
            Some(ViewInput::Release)
        );
        assert_eq!(
            parse_input(r#"{"type":"fault","fault":{"kind":"engine-failure"}}"#).ok(),
            Some(ViewInput::Fault(r#"{"kind":"engine-failure"}"#.into()))
        );
        for (bad, says) in [
            (
                r#"{"type":"pilot","aileron":2,"elevator":0,"rudder":0,"collective":0,"throttle":0.8,"auto":true,"bypass":false}"#,
                "aileron 2",
            ),
            (
                r#"{"type":"pilot","aileron":0,"elevator":0,"rudder":0,"collective":0,"throttle":-0.1,"auto":true,"bypass":false}"#,
                "throttle -0.1",
            ),
            (r#"{"type":"pilot","aileron":0}"#, "missing field"),
            (
                r#"{"type":"pilot","aileron":0,"elevator":0,"rudder":0,"collective":0,"throttle":0.8,"auto":true,"bypass":false,"flaps":1}"#,
                "unknown field `flaps`",
            ),
            (r#"{"type":"fault"}"#, "no `fault` object"),
            (r#"{"type":"launch"}"#, "unknown message type 'launch'"),
            ("{]", "not JSON"),
        ] {
            let err = parse_input(bad).unwrap_err().to_string();
            assert!(err.contains(says), "{bad}: {err}");
        }
    }
}
