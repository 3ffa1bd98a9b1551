//! The HILSim's view of the flying helicopter (`heli hilsim --view ADDR`): a web page that
//! draws the simulator's truth in 3D — the X-Cell with its rotor disk tilting with the
//! flapping, the field's grid and the take-off point, the flight plan, a trail, a chase
//! camera and a fixed field camera, the wind. It is the truth, labelled so; the ground
//! display (`heli ground --http`) draws the vehicle's estimate and says so.
//!
//! The simulator publishes a frame (JSON) whenever it likes ([`TruthFeed::publish`]); each
//! page gets the setup (the plan, the scenario's name) once and then the newest frame at most
//! 30 times a second, whatever the simulation's speed. The page's files are embedded like
//! the display's. The feed is read-only: nothing a page sends reaches the simulator.

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
}

/// Serves the view on `addr` from a thread of its own; returns the address it is served on
/// (port 0 picks a free one) and the feed. `setup_json` goes to every page first.
pub fn spawn(addr: SocketAddr, setup_json: String) -> Result<(SocketAddr, TruthFeed), String> {
    let (frames, rx) = watch::channel(Arc::<str>::from(""));
    let state = ViewState {
        setup: Arc::from(setup_json),
        frames: rx,
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
/// [`FRAME_EVERY`]; ends when the page goes.
async fn feed(mut socket: WebSocket, mut state: ViewState) {
    let setup = WsMessage::Text(state.setup.to_string().into());
    if socket.send(setup).await.is_err() {
        return;
    }
    loop {
        if state.frames.changed().await.is_err() {
            return;
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
        tokio::time::sleep(FRAME_EVERY).await;
    }
}
