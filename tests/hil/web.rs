//! The workstation's pages as someone who wants in would try them, over raw TCP: the
//! operator's display (`heli ground --http`) lets in only pages with its key, reached by its
//! own address, from its own origin, unframed; an observer's key watches and never commands.

use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::Duration;

use crate::procs::{Display, free_udp_port};

/// `http://ADDR/PATH?QUERY` → (`ADDR`, `/PATH?QUERY`).
pub fn split_url(url: &str) -> (String, String) {
    let rest = url.trim_start_matches("http://");
    match rest.find('/') {
        Some(i) => (rest[..i].to_string(), rest[i..].to_string()),
        None => (rest.to_string(), "/".to_string()),
    }
}

/// Sends `request` to `addr` and reads the answer's head and the start of its body.
pub fn raw(addr: &str, request: &str) -> String {
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    s.write_all(request.as_bytes()).unwrap();
    let mut buf = vec![0u8; 65_536];
    let mut got = Vec::new();
    // A WebSocket that is accepted stays open: read what came, not to the end.
    while let Ok(n) = s.read(&mut buf) {
        if n == 0 {
            break;
        }
        got.extend_from_slice(&buf[..n]);
        if request.contains("Upgrade: websocket") {
            break;
        }
    }
    String::from_utf8_lossy(&got).into_owned()
}

/// The `Set-Cookie` of an answer (name=value only).
pub fn cookie_of(answer: &str) -> String {
    answer
        .lines()
        .find_map(|l| {
            l.strip_prefix("set-cookie: ")
                .or(l.strip_prefix("Set-Cookie: "))
        })
        .and_then(|c| c.split(';').next())
        .unwrap_or_else(|| panic!("no cookie in {answer}"))
        .to_string()
}

/// Logs in with the key in `url`; returns the cookie.
pub fn login(url: &str) -> String {
    let (addr, path) = split_url(url);
    let answer = raw(
        &addr,
        &format!("GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n"),
    );
    assert!(answer.starts_with("HTTP/1.1 303"), "{answer}");
    cookie_of(&answer)
}

/// GET `path` with `cookie`.
pub fn get(addr: &str, path: &str, cookie: &str) -> String {
    raw(
        addr,
        &format!(
            "GET {path} HTTP/1.1\r\nHost: {addr}\r\nCookie: {cookie}\r\nConnection: close\r\n\r\n"
        ),
    )
}

/// A WebSocket handshake with these headers (`Host` and the rest as given).
fn handshake(addr: &str, headers: &str) -> String {
    raw(
        addr,
        &format!(
            "GET /ws HTTP/1.1\r\n{headers}Connection: Upgrade\r\nUpgrade: websocket\r\nSec-WebSocket-Version: 13\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n\r\n"
        ),
    )
}

/// Opens a WebSocket with `cookie`, sends `text` as one masked frame, and returns the first
/// `reply` the server sends back.
fn ws_request(addr: &str, cookie: &str, text: &str) -> String {
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    write!(
        s,
        "GET /ws HTTP/1.1\r\nHost: {addr}\r\nOrigin: http://{addr}\r\nCookie: {cookie}\r\nConnection: Upgrade\r\nUpgrade: websocket\r\nSec-WebSocket-Version: 13\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n\r\n"
    )
    .unwrap();
    // The head of the 101 answer, to its blank line.
    let mut head = Vec::new();
    let mut byte = [0u8; 1];
    while !head.ends_with(b"\r\n\r\n") {
        s.read_exact(&mut byte).unwrap();
        head.push(byte[0]);
    }
    assert!(
        head.starts_with(b"HTTP/1.1 101"),
        "{}",
        String::from_utf8_lossy(&head)
    );
    let mask = [1u8, 2, 3, 4];
    let mut frame = vec![0x81, 0x80 | u8::try_from(text.len()).unwrap()];
    frame.extend_from_slice(&mask);
    frame.extend(text.bytes().enumerate().map(|(i, b)| b ^ mask[i % 4]));
    s.write_all(&frame).unwrap();
    for _ in 0..200 {
        let mut h = [0u8; 2];
        s.read_exact(&mut h).unwrap();
        let len = match h[1] & 0x7f {
            126 => {
                let mut l = [0u8; 2];
                s.read_exact(&mut l).unwrap();
                usize::from(u16::from_be_bytes(l))
            }
            127 => {
                let mut l = [0u8; 8];
                s.read_exact(&mut l).unwrap();
                usize::try_from(u64::from_be_bytes(l)).unwrap()
            }
            n => usize::from(n),
        };
        let mut payload = vec![0u8; len];
        s.read_exact(&mut payload).unwrap();
        let text = String::from_utf8_lossy(&payload).into_owned();
        if text.contains("\"type\":\"reply\"") {
            return text;
        }
    }
    panic!("no reply")
}

#[test]
fn the_display_lets_in_only_its_operator_and_observers_with_their_keys() {
    crate::procs::void_if_starved(|| {
        let dir = tempfile::tempdir().unwrap();
        let link = format!("udp:127.0.0.1:{}", free_udp_port());
        let display = Display::start(&link, None, dir.path());
        let (addr, _) = split_url(&display.url);
        let port = addr.rsplit(':').next().unwrap().to_string();
        // A local user who was not given the key: refused, told where the key is.
        let answer = raw(
            &addr,
            &format!("GET / HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n"),
        );
        assert!(answer.starts_with("HTTP/1.1 401"), "{answer}");
        assert!(answer.contains("needs its key"), "{answer}");
        // The key in the address: an HttpOnly, SameSite=Strict cookie, the key out of the bar.
        let (_, path) = split_url(&display.url);
        let answer = raw(
            &addr,
            &format!("GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n"),
        );
        assert!(answer.starts_with("HTTP/1.1 303"), "{answer}");
        let lower = answer.to_ascii_lowercase();
        assert!(lower.contains("location: /\r\n"), "{answer}");
        assert!(
            lower.contains("httponly") && lower.contains("samesite=strict"),
            "{answer}"
        );
        let cookie = cookie_of(&answer);
        // With it: the page, never framed, its scripts its own.
        let page = get(&addr, "/", &cookie);
        assert!(page.starts_with("HTTP/1.1 200"), "{page}");
        let lower = page.to_ascii_lowercase();
        assert!(lower.contains("x-frame-options: deny"), "{page}");
        assert!(lower.contains("frame-ancestors 'none'"), "{page}");
        assert!(lower.contains("script-src 'self'"), "{page}");
        // The DNS-rebinding handshake of the finding, with the cookie even: refused.
        let answer = handshake(
            &addr,
            &format!(
                "Host: evil.example:{port}\r\nOrigin: http://evil.example:{port}\r\nCookie: {cookie}\r\n"
            ),
        );
        assert!(answer.starts_with("HTTP/1.1 403"), "{answer}");
        // No Origin (not a browser's page): refused.
        let answer = handshake(&addr, &format!("Host: {addr}\r\nCookie: {cookie}\r\n"));
        assert!(answer.starts_with("HTTP/1.1 403"), "{answer}");
        assert!(answer.contains("without an Origin"), "{answer}");
        // Another site's page: refused.
        let answer = handshake(
            &addr,
            &format!("Host: {addr}\r\nOrigin: http://evil.example\r\nCookie: {cookie}\r\n"),
        );
        assert!(answer.starts_with("HTTP/1.1 403"), "{answer}");
        // This page's origin but no key (a local request signed on its behalf before): refused.
        let answer = handshake(&addr, &format!("Host: {addr}\r\nOrigin: http://{addr}\r\n"));
        assert!(answer.starts_with("HTTP/1.1 401"), "{answer}");
        // The operator takes control; an observer may watch but never take it.
        let reply = ws_request(&addr, &cookie, r#"{"seq":1,"op":"take"}"#);
        assert!(reply.contains("\"ok\":true"), "{reply}");
        let observer = login(&display.observer_url);
        assert_ne!(observer, cookie);
        let reply = ws_request(&addr, &observer, r#"{"seq":1,"op":"take"}"#);
        assert!(
            reply.contains("\"ok\":false") && reply.contains("observer"),
            "{reply}"
        );
        assert!(display.stop());
    });
}
