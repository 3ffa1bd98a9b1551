//! The HILSim's view of the flying helicopter (`heli hilsim --view ADDR`): a web page that
//! draws the simulator's truth in 3D — the X-Cell with its rotor disk tilting with the
//! flapping, the field's grid and the take-off point, the flight plan, a trail, a chase
//! camera and a fixed field camera, the wind. It is the truth, labelled so; the ground
//! display (`heli ground --http`) draws the vehicle's estimate and says so.
//!
//! The simulator publishes a frame (JSON) whenever it likes ([`TruthFeed::publish`]); each
//! page gets the setup (the plan, the scenario's name) once and then the newest frame at most
//! 30 times a second, whatever the simulation's speed. The page's files are embedded like
//! the display's.
//!
//! Served read-only, nothing a page sends reaches the simulator. Served with a control
//! channel (`heli hilsim --pilot`), a page may hold the transmitter — its sticks and
//! switches, [`PilotFrame`], checked here — hand it back, and trigger failures (passed on as
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
use tokio::sync::watch;

/// Longest between two frames to a page.
const FRAME_EVERY: Duration = Duration::from_millis(33);

/// What a page sends the simulator.
#[derive(Clone, Debug, PartialEq)]
pub enum ViewInput {
    /// The page holds the transmitter: its sticks and switches now.
    Pilot(PilotFrame),
    /// The page hands the transmitter back to the scenario's pilot.
    Release,
    /// Trigger a failure: the request as the page wrote it (JSON with a `kind`).
    Fault(String),
}

/// A transmitter's sticks and switches as a page sends them.
#[derive(Clone, Copy, Debug, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PilotFrame {
    /// Lateral cyclic, −1..1 (right positive).
    pub aileron: f64,
    /// Longitudinal cyclic, −1..1 (aft positive).
    pub elevator: f64,
    /// Tail, −1..1.
    pub rudder: f64,
    /// Collective, −1..1.
    pub collective: f64,
    /// Throttle, 0..1.
    pub throttle: f64,
    /// The auto switch.
    pub auto: bool,
    /// The emergency bypass switch.
    pub bypass: bool,
}

impl PilotFrame {
    /// Checks every channel is a number in its range, naming the first that is not.
    pub fn check(&self) -> Result<(), String> {
        for (name, v, lo) in [
            ("aileron", self.aileron, -1.0),
            ("elevator", self.elevator, -1.0),
            ("rudder", self.rudder, -1.0),
            ("collective", self.collective, -1.0),
            ("throttle", self.throttle, 0.0),
        ] {
            if !(v.is_finite() && (lo..=1.0).contains(&v)) {
                return Err(format!("pilot {name} {v}: must be within {lo}..1"));
            }
        }
        Ok(())
    }
}

/// Reads one message from a page: what it asks, or why it is refused.
pub fn parse_input(text: &str) -> Result<ViewInput, String> {
    let value: serde_json::Value =
        serde_json::from_str(text).map_err(|e| format!("not JSON ({e}): {text:.80}"))?;
    let kind = value.get("type").and_then(|t| t.as_str()).unwrap_or("");
    match kind {
        "pilot" => {
            let mut fields = value.clone();
            if let Some(map) = fields.as_object_mut() {
                map.remove("type");
            }
            let frame: PilotFrame =
                serde_json::from_value(fields).map_err(|e| format!("pilot message: {e}"))?;
            frame.check()?;
            Ok(ViewInput::Pilot(frame))
        }
        "release" => Ok(ViewInput::Release),
        "fault" => match value.get("fault") {
            Some(fault) if fault.is_object() => Ok(ViewInput::Fault(fault.to_string())),
            _ => Err("fault message: no `fault` object".into()),
        },
        other => Err(format!(
            "unknown message type '{other}' (pilot, release, fault)"
        )),
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
}

/// Serves the view on `addr` from a thread of its own; returns the address it is served on
/// (port 0 picks a free one) and the feed. `setup_json` goes to every page first. With
/// `control`, what pages send goes there ([`ViewInput`]); without, it is refused.
pub fn spawn(
    addr: SocketAddr,
    setup_json: String,
    control: Option<std::sync::mpsc::Sender<ViewInput>>,
) -> Result<(SocketAddr, TruthFeed), String> {
    let (frames, rx) = watch::channel(Arc::<str>::from(""));
    let state = ViewState {
        setup: Arc::from(setup_json),
        frames: rx,
        control,
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
                    let _ = bound_tx.send(Err(format!("starting the view's runtime: {e}")));
                    return;
                }
            };
            rt.block_on(async move {
                let listener = match tokio::net::TcpListener::bind(addr).await {
                    Ok(l) => l,
                    Err(e) => {
                        let _ = bound_tx.send(Err(format!("serving the view on {addr}: {e}")));
                        return;
                    }
                };
                let _ = bound_tx.send(
                    listener
                        .local_addr()
                        .map_err(|e| format!("serving the view: {e}")),
                );
                let app = Router::new()
                    .route("/", get(page))
                    .route("/ws", get(ws))
                    .fallback(crate::server::asset)
                    .with_state(state);
                let _ = axum::serve(listener, app).await;
            });
        })
        .map_err(|e| format!("starting the view's thread: {e}"))?;
    let bound = bound_rx
        .recv()
        .map_err(|_| "the view's thread ended before serving".to_string())??;
    Ok((bound, TruthFeed { frames }))
}

async fn page() -> Response {
    crate::server::asset(Uri::from_static("/truth.html")).await
}

async fn ws(upgrade: WebSocketUpgrade, State(state): State<ViewState>) -> Response {
    upgrade
        .max_message_size(1024)
        .on_upgrade(move |socket| feed(socket, state))
        .into_response()
}

/// The setup, then the newest frame whenever there is a new one, at most every
/// [`FRAME_EVERY`]; what the page sends goes to the control channel, or is refused. Ends
/// when the page goes.
async fn feed(mut socket: WebSocket, mut state: ViewState) {
    let setup = WsMessage::Text(state.setup.to_string().into());
    if socket.send(setup).await.is_err() {
        return;
    }
    let mut tick = tokio::time::interval(FRAME_EVERY);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    loop {
        tokio::select! {
            _ = tick.tick() => {
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
                    (Some(_), Err(e)) => Some(e),
                    (Some(control), Ok(input)) => control
                        .send(input)
                        .err()
                        .map(|_| "the simulator has stopped".to_string()),
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
        assert_eq!(parse_input(r#"{"type":"release"}"#), Ok(ViewInput::Release));
        assert_eq!(
            parse_input(r#"{"type":"fault","fault":{"kind":"engine-failure"}}"#),
            Ok(ViewInput::Fault(r#"{"kind":"engine-failure"}"#.into()))
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
            let err = parse_input(bad).unwrap_err();
            assert!(err.contains(says), "{bad}: {err}");
        }
    }
}
