//! The gate against each way in that was found open: a rebinding `Host`, a WebSocket without
//! an `Origin` or from another site, a request without the key, a framed page.

use super::*;

const OP: &str = "0123456789abcdef0123456789abcdef";
const OBS: &str = "fedcba9876543210fedcba9876543210";

fn gate() -> Gate {
    Gate::with_keys(
        "ground",
        8080,
        vec!["groundstation.lab".into()],
        OP.into(),
        OBS.into(),
    )
}

fn headers(pairs: &[(&'static str, &str)]) -> HeaderMap {
    let mut h = HeaderMap::new();
    for (name, value) in pairs {
        h.append(*name, HeaderValue::from_str(value).unwrap());
    }
    h
}

fn ws(host: &str, origin: Option<&str>, cookie: Option<&str>) -> HeaderMap {
    let mut pairs = vec![
        ("host", host),
        ("upgrade", "websocket"),
        ("connection", "Upgrade"),
    ];
    if let Some(o) = origin {
        pairs.push(("origin", o));
    }
    let c;
    if let Some(k) = cookie {
        c = format!("other=1; heli_ground_8080={k}");
        pairs.push(("cookie", &c));
    }
    headers(&pairs)
}

fn refused(d: Decision, status: StatusCode, words: &str) {
    match d {
        Decision::Refuse(s, why) => {
            assert_eq!(s, status, "{why}");
            assert!(why.contains(words), "{why}");
        }
        other => panic!("not refused: {other:?}"),
    }
}

#[test]
fn a_rebinding_host_is_refused_and_ip_literals_localhost_and_allowed_names_pass() {
    let g = gate();
    let root = Uri::from_static("/");
    let cookie = format!("heli_ground_8080={OP}");
    for host in [
        "evil.example:8080",
        "127.0.0.1:9999",
        "",
        "evil.example",
        "[::1]",
    ] {
        refused(
            g.decide(&root, &headers(&[("host", host), ("cookie", &cookie)])),
            StatusCode::FORBIDDEN,
            "DNS rebinding",
        );
    }
    for host in [
        "127.0.0.1:8080",
        "192.168.1.20:8080",
        "[::1]:8080",
        "localhost:8080",
        "GroundStation.lab:8080",
    ] {
        assert_eq!(
            g.decide(&root, &headers(&[("host", host), ("cookie", &cookie)])),
            Decision::Pass(Role::Operator),
            "{host}"
        );
    }
    let at_80 = Gate::with_keys("view", 80, vec![], OP.into(), OBS.into());
    assert!(at_80.host_allowed("localhost"));
    assert!(!at_80.host_allowed("localhost:8080"));
}

#[test]
fn the_rebinding_handshake_of_the_finding_is_refused() {
    // Host: evil.example:PORT, Origin: http://evil.example:PORT — consistent, and refused.
    refused(
        gate().decide(
            &Uri::from_static("/ws"),
            &ws(
                "evil.example:8080",
                Some("http://evil.example:8080"),
                Some(OP),
            ),
        ),
        StatusCode::FORBIDDEN,
        "DNS rebinding",
    );
}

#[test]
fn a_websocket_needs_this_pages_origin_and_the_key() {
    let g = gate();
    let uri = Uri::from_static("/ws");
    refused(
        g.decide(&uri, &ws("127.0.0.1:8080", None, Some(OP))),
        StatusCode::FORBIDDEN,
        "without an Origin",
    );
    refused(
        g.decide(
            &uri,
            &ws("127.0.0.1:8080", Some("http://evil.example"), Some(OP)),
        ),
        StatusCode::FORBIDDEN,
        "from http://evil.example",
    );
    refused(
        g.decide(
            &uri,
            &ws("127.0.0.1:8080", Some("http://127.0.0.1:8080"), None),
        ),
        StatusCode::UNAUTHORIZED,
        "needs its key",
    );
    refused(
        g.decide(
            &uri,
            &ws(
                "127.0.0.1:8080",
                Some("http://127.0.0.1:8080"),
                Some("guess"),
            ),
        ),
        StatusCode::UNAUTHORIZED,
        "needs its key",
    );
    assert_eq!(
        g.decide(
            &uri,
            &ws("127.0.0.1:8080", Some("http://127.0.0.1:8080"), Some(OP))
        ),
        Decision::Pass(Role::Operator)
    );
    assert_eq!(
        g.decide(
            &uri,
            &ws("127.0.0.1:8080", Some("http://127.0.0.1:8080"), Some(OBS))
        ),
        Decision::Pass(Role::Observer)
    );
}

#[test]
fn the_key_in_the_address_becomes_a_strict_http_only_cookie_and_a_wrong_one_is_refused() {
    let g = gate();
    let host = headers(&[("host", "127.0.0.1:8080")]);
    refused(
        g.decide(&Uri::from_static("/"), &host),
        StatusCode::UNAUTHORIZED,
        "open the address the server printed",
    );
    let with_key: Uri = format!("/?key={OP}").parse().unwrap();
    assert_eq!(
        g.decide(&with_key, &host),
        Decision::Login {
            key: OP.into(),
            location: "/".into()
        }
    );
    // The page's own settings stay in the address; only the key leaves it.
    let with_settings: Uri = format!("/?camera=chase&key={OP}&pilot=-20,5")
        .parse()
        .unwrap();
    assert_eq!(
        g.decide(&with_settings, &host),
        Decision::Login {
            key: OP.into(),
            location: "/?camera=chase&pilot=-20,5".into()
        }
    );
    assert_eq!(
        g.set_cookie(OP),
        format!("heli_ground_8080={OP}; HttpOnly; SameSite=Strict; Path=/")
    );
    refused(
        g.decide(&Uri::from_static("/?key=0123"), &host),
        StatusCode::UNAUTHORIZED,
        "needs its key",
    );
    let addr: SocketAddr = "0.0.0.0:8080".parse().unwrap();
    assert_eq!(
        g.operator_url(addr),
        format!("http://127.0.0.1:8080/?key={OP}")
    );
    assert_eq!(
        g.observer_url(addr),
        format!("http://127.0.0.1:8080/?key={OBS}")
    );
}

#[test]
fn every_answer_forbids_framing_and_foreign_scripts() {
    let mut r = StatusCode::OK.into_response();
    harden(&mut r);
    let h = r.headers();
    assert_eq!(h[header::X_FRAME_OPTIONS], "DENY");
    let csp = h[header::CONTENT_SECURITY_POLICY].to_str().unwrap();
    assert!(csp.contains("frame-ancestors 'none'") && csp.contains("script-src 'self'"));
    assert_eq!(h[header::REFERRER_POLICY], "no-referrer");
    assert!(constant_time_eq("abc", "abc") && !constant_time_eq("abc", "abd"));
    assert!(!constant_time_eq("abc", "abcd"));
}
