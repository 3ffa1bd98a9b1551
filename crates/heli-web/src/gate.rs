//! Who may open a page and its WebSocket: the gate every workstation page is served through.
//!
//! - **A key per run.** The server makes two random keys when it starts (or takes them from
//!   [`KEY_ENV`] / [`OBSERVER_KEY_ENV`], so that a server started again keeps its pages): the
//!   operator's and the observer's. It prints the page's address with the key
//!   (`http://127.0.0.1:8080/?key=…`); opening it exchanges the key for an `HttpOnly`,
//!   `SameSite=Strict` cookie and drops it from the address bar. Every request — page, file
//!   and WebSocket — needs the cookie (or the key); without it the answer is 401 and says
//!   where the key is. Another local user, who cannot read the operator's terminal, has no key.
//! - **Hosts.** The `Host` header must name this server: an IP address literal, `localhost`,
//!   or a name given with `--allow-host`, at the served port. A page reached by a DNS name
//!   that now points here (DNS rebinding) is refused.
//! - **Origins.** A WebSocket must carry an `Origin`, and it must be this very page's
//!   (`http://` + the `Host`): a page of another site cannot drive the socket, and a client
//!   that sends no `Origin` (not a browser) is refused too.
//! - **Framing.** Every answer forbids framing (`X-Frame-Options: DENY`, CSP
//!   `frame-ancestors 'none'`) and loads scripts only from the page's own files.
//! - **Roles.** The operator's key may command (take the control token, the transmitter); the
//!   observer's may only watch ([`Role`]; the servers ask it of each page).

use std::net::{IpAddr, SocketAddr};
use std::sync::Arc;

use axum::extract::{Request, State};
use axum::http::{HeaderMap, HeaderValue, StatusCode, Uri, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};

/// The environment variable that gives the operator's key instead of a random one.
pub const KEY_ENV: &str = "HELI_WEB_KEY";
/// The environment variable that gives the observer's key instead of a random one.
pub const OBSERVER_KEY_ENV: &str = "HELI_WEB_OBSERVER_KEY";
/// The content security policy of every page: its own files only, no framing.
pub const CSP: &str = "default-src 'self'; script-src 'self'; style-src 'self' 'unsafe-inline'; img-src 'self' data:; connect-src 'self'; frame-ancestors 'none'; base-uri 'none'; form-action 'none'";
/// Shortest key taken from the environment (characters).
const MIN_KEY_LEN: usize = 16;

/// What a page may do.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// May command (take the control token, the transmitter).
    Operator,
    /// May watch only.
    Observer,
}

/// The gate of one server.
#[derive(Clone, Debug)]
pub struct Gate {
    operator_key: String,
    observer_key: String,
    cookie: String,
    port: u16,
    hosts: Vec<String>,
}

/// What the gate does with a request.
#[derive(Debug, PartialEq)]
pub enum Decision {
    /// Served, to a page of this role.
    Pass(Role),
    /// The key in the address: set the cookie and send the browser to the address without it.
    Login {
        /// The cookie's value.
        key: String,
        /// Where to go.
        location: String,
    },
    /// Refused: the status and why.
    Refuse(StatusCode, String),
}

/// Why the gate could not be made.
#[derive(Debug)]
pub enum GateError {
    /// No random key: `/dev/urandom` could not be read.
    Random(std::io::Error),
    /// A key from the environment is too short or not printable ASCII.
    BadKey(&'static str),
}

impl std::fmt::Display for GateError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            GateError::Random(e) => write!(f, "making the page's key (/dev/urandom): {e}"),
            GateError::BadKey(var) => write!(
                f,
                "{var}: a page key is at least {MIN_KEY_LEN} letters, digits, '-' or '_'"
            ),
        }
    }
}

impl std::error::Error for GateError {}

/// A new random key (32 hex digits from `/dev/urandom`): for a program that starts servers
/// and gives them one key through [`KEY_ENV`].
pub fn new_key() -> Result<String, GateError> {
    random_key()
}

fn random_key() -> Result<String, GateError> {
    use std::io::Read;
    let mut bytes = [0u8; 16];
    std::fs::File::open("/dev/urandom")
        .and_then(|mut f| f.read_exact(&mut bytes))
        .map_err(GateError::Random)?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

fn key_from(var: &'static str) -> Result<String, GateError> {
    match std::env::var(var) {
        Ok(key) => {
            let ok = key.len() >= MIN_KEY_LEN
                && key
                    .bytes()
                    .all(|b| b.is_ascii_alphanumeric() || b == b'-' || b == b'_');
            if ok {
                Ok(key)
            } else {
                Err(GateError::BadKey(var))
            }
        }
        Err(_) => random_key(),
    }
}

impl Gate {
    /// The gate of a server at `port` whose cookie is named after `name` (`ground`, `view`):
    /// keys from the environment or random; `hosts`: names besides IP literals and
    /// `localhost` that may reach it.
    pub fn new(name: &str, port: u16, hosts: Vec<String>) -> Result<Self, GateError> {
        Ok(Self::with_keys(
            name,
            port,
            hosts,
            key_from(KEY_ENV)?,
            key_from(OBSERVER_KEY_ENV)?,
        ))
    }

    /// A gate with these keys (tests).
    pub fn with_keys(
        name: &str,
        port: u16,
        hosts: Vec<String>,
        operator_key: String,
        observer_key: String,
    ) -> Self {
        Self {
            operator_key,
            observer_key,
            // Cookies are kept per host, not per port: the port keeps two servers apart.
            cookie: format!("heli_{name}_{port}"),
            port,
            hosts: hosts.into_iter().map(|h| h.to_ascii_lowercase()).collect(),
        }
    }

    /// The address to open as the operator, for a server bound at `addr` (an unspecified
    /// address is reached at 127.0.0.1).
    pub fn operator_url(&self, addr: SocketAddr) -> String {
        format!("{}?key={}", base_url(addr), self.operator_key)
    }

    /// The address to open as an observer (watching only).
    pub fn observer_url(&self, addr: SocketAddr) -> String {
        format!("{}?key={}", base_url(addr), self.observer_key)
    }

    /// Whether `host` (a `Host` header) names this server.
    pub fn host_allowed(&self, host: &str) -> bool {
        // `name:port`, `[v6]:port`, or a bare name at the default port.
        let (name, port) = match host.rsplit_once(':') {
            Some((name, port))
                if !port.contains(']') && (!name.contains(':') || name.ends_with(']')) =>
            {
                (name, port.parse::<u16>().ok())
            }
            _ => (host, Some(80)),
        };
        if port != Some(self.port) {
            return false;
        }
        let name = name.to_ascii_lowercase();
        let literal = name.trim_start_matches('[').trim_end_matches(']');
        literal.parse::<IpAddr>().is_ok() || name == "localhost" || self.hosts.contains(&name)
    }

    fn role_of(&self, key: &str) -> Option<Role> {
        if constant_time_eq(key, &self.operator_key) {
            Some(Role::Operator)
        } else if constant_time_eq(key, &self.observer_key) {
            Some(Role::Observer)
        } else {
            None
        }
    }

    /// What to do with a request for `uri` with `headers`.
    pub fn decide(&self, uri: &Uri, headers: &HeaderMap) -> Decision {
        let host = headers
            .get(header::HOST)
            .and_then(|h| h.to_str().ok())
            .unwrap_or("");
        if !self.host_allowed(host) {
            return Decision::Refuse(
                StatusCode::FORBIDDEN,
                format!(
                    "Host '{host:.80}' is not this server's (a name that now points here is refused: DNS rebinding); open it by its IP address or localhost, or allow the name with --allow-host"
                ),
            );
        }
        let websocket = headers
            .get(header::UPGRADE)
            .and_then(|u| u.to_str().ok())
            .is_some_and(|u| u.eq_ignore_ascii_case("websocket"));
        if websocket {
            let origin = headers.get(header::ORIGIN).and_then(|h| h.to_str().ok());
            let own = format!("http://{host}");
            match origin {
                None => {
                    return Decision::Refuse(
                        StatusCode::FORBIDDEN,
                        "WebSocket without an Origin refused: only this server's pages".into(),
                    );
                }
                Some(o) if !o.eq_ignore_ascii_case(&own) => {
                    return Decision::Refuse(
                        StatusCode::FORBIDDEN,
                        format!("WebSocket from {o:.80} refused: only this server's pages"),
                    );
                }
                Some(_) => {}
            }
        }
        if let Some(key) = query_key(uri)
            && !websocket
        {
            return match self.role_of(key) {
                Some(_) => Decision::Login {
                    key: key.to_string(),
                    location: without_key(uri),
                },
                None => Decision::Refuse(StatusCode::UNAUTHORIZED, not_the_key()),
            };
        }
        match cookie(headers, &self.cookie).and_then(|k| self.role_of(k)) {
            Some(role) => Decision::Pass(role),
            None => Decision::Refuse(StatusCode::UNAUTHORIZED, not_the_key()),
        }
    }

    /// The cookie that keeps `key` for this server's pages.
    pub fn set_cookie(&self, key: &str) -> String {
        format!("{}={key}; HttpOnly; SameSite=Strict; Path=/", self.cookie)
    }
}

fn not_the_key() -> String {
    "this page needs its key: open the address the server printed when it started (http://…/?key=…)"
        .into()
}

fn base_url(addr: SocketAddr) -> String {
    let ip = match addr.ip() {
        ip if ip.is_unspecified() && ip.is_ipv4() => "127.0.0.1".to_string(),
        ip if ip.is_unspecified() => "[::1]".to_string(),
        IpAddr::V6(ip) => format!("[{ip}]"),
        IpAddr::V4(ip) => ip.to_string(),
    };
    format!("http://{ip}:{}/", addr.port())
}

/// Where a page's address points once its key is a cookie: the same path and query, less
/// the key (the page's own settings, `?camera=chase`, stay).
fn without_key(uri: &Uri) -> String {
    let rest: Vec<&str> = uri
        .query()
        .into_iter()
        .flat_map(|q| q.split('&'))
        .filter(|pair| !pair.is_empty() && !pair.starts_with("key="))
        .collect();
    if rest.is_empty() {
        uri.path().to_string()
    } else {
        format!("{}?{}", uri.path(), rest.join("&"))
    }
}

/// The `key` parameter of the query, if any.
fn query_key(uri: &Uri) -> Option<&str> {
    uri.query()?
        .split('&')
        .find_map(|pair| pair.strip_prefix("key="))
}

/// The value of cookie `name`.
fn cookie<'a>(headers: &'a HeaderMap, name: &str) -> Option<&'a str> {
    headers
        .get_all(header::COOKIE)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(';'))
        .filter_map(|pair| pair.trim().split_once('='))
        .find(|(n, _)| *n == name)
        .map(|(_, v)| v)
}

/// Equality that takes as long whatever the first difference (the key is a secret).
fn constant_time_eq(a: &str, b: &str) -> bool {
    a.len() == b.len()
        && a.bytes()
            .zip(b.bytes())
            .fold(0u8, |acc, (x, y)| acc | (x ^ y))
            == 0
}

/// The headers every answer carries: no framing, scripts from the page's own files, no
/// guessing of types, no referrer (the key never leaves in one).
pub fn harden(response: &mut Response) {
    let h = response.headers_mut();
    h.insert(header::X_FRAME_OPTIONS, HeaderValue::from_static("DENY"));
    h.insert(
        header::CONTENT_SECURITY_POLICY,
        HeaderValue::from_static(CSP),
    );
    h.insert(
        header::X_CONTENT_TYPE_OPTIONS,
        HeaderValue::from_static("nosniff"),
    );
    h.insert(
        header::REFERRER_POLICY,
        HeaderValue::from_static("no-referrer"),
    );
}

/// The gate as an axum middleware: refused requests get their reason, a key in the address
/// becomes the cookie, and a request let through carries its page's [`Role`] as an extension.
pub async fn guard(State(gate): State<Arc<Gate>>, mut request: Request, next: Next) -> Response {
    let mut response = match gate.decide(request.uri(), request.headers()) {
        Decision::Refuse(status, why) => (status, why).into_response(),
        Decision::Login { key, location } => {
            let mut r = (
                StatusCode::SEE_OTHER,
                [
                    (header::LOCATION, location),
                    (header::SET_COOKIE, gate.set_cookie(&key)),
                    (header::CACHE_CONTROL, "no-store".to_string()),
                ],
            )
                .into_response();
            harden(&mut r);
            return r;
        }
        Decision::Pass(role) => {
            request.extensions_mut().insert(role);
            next.run(request).await
        }
    };
    harden(&mut response);
    response
}

#[cfg(test)]
#[path = "gate_tests.rs"]
mod tests;
