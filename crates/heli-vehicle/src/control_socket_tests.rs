//! The control socket's place and its bounds, on real sockets in a temporary directory.

use super::*;
use std::io::Write;
use std::os::unix::fs::symlink;

fn private_dir() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    fs::set_permissions(dir.path(), fs::Permissions::from_mode(0o700))
        .unwrap_or_else(|e| panic!("{e}"));
    dir
}

#[test]
fn bound_it_is_0600_whatever_the_umask_and_its_missing_directory_is_made_0700() {
    let dir = private_dir();
    let path = dir.path().join("run").join("heli").join("vehicle.sock");
    let listener = bind(&path).unwrap_or_else(|e| panic!("{e:?}"));
    assert!(listener.is_some());
    let mode = fs::metadata(&path).map(|m| m.mode() & 0o777).unwrap_or(0);
    assert_eq!(mode, 0o600);
    let parent = path.parent().map(fs::metadata);
    assert!(matches!(parent, Some(Ok(m)) if m.mode() & 0o777 == 0o700));
    // A second bootstrap on the same path finds the first answering.
    assert!(matches!(bind(&path), Ok(None)));
    // The first gone, its socket is stale and replaced.
    drop(listener);
    assert!(matches!(bind(&path), Ok(Some(_))));
}

#[test]
fn a_directory_others_may_write_in_or_a_squatted_path_is_refused() {
    let dir = private_dir();
    let open = dir.path().join("open");
    fs::create_dir(&open).unwrap_or_else(|e| panic!("{e}"));
    fs::set_permissions(&open, fs::Permissions::from_mode(0o777)).unwrap_or_else(|e| panic!("{e}"));
    let e = bind(&open.join("vehicle.sock")).map(|_| ()).unwrap_err();
    let text = match e {
        BindError::Unsafe(why) => why.to_string(),
        BindError::Io(e) => panic!("{e}"),
    };
    assert!(text.contains("writable by others (mode 777)"), "{text}");
    // Sticky, as /tmp: others cannot remove what is ours there.
    fs::set_permissions(&open, fs::Permissions::from_mode(0o1777))
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(matches!(bind(&open.join("vehicle.sock")), Ok(Some(_))));
    // Not a socket at the path (a file, a symbolic link someone left): not replaced.
    let path = dir.path().join("vehicle.sock");
    fs::write(&path, b"").unwrap_or_else(|e| panic!("{e}"));
    let e = bind(&path).map(|_| ()).unwrap_err();
    assert!(
        matches!(e, BindError::Unsafe(Unsafe::Squatted(..))),
        "{e:?}"
    );
    fs::remove_file(&path).unwrap_or_else(|e| panic!("{e}"));
    symlink("/etc/passwd", &path).unwrap_or_else(|e| panic!("{e}"));
    let e = bind(&path).map(|_| ()).unwrap_err();
    let text = match e {
        BindError::Unsafe(why) => why.to_string(),
        BindError::Io(e) => panic!("{e}"),
    };
    assert!(
        text.contains("is not a socket") && text.contains("not replaced"),
        "{text}"
    );
    assert!(fs::symlink_metadata(&path).is_ok(), "left where it was");
}

#[test]
fn a_peer_of_the_same_user_may_command() {
    let (a, _b) = UnixStream::pair().unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(peer_allowed(&a), Ok(()));
}

fn client(line: &[u8]) -> UnixStream {
    let (mut ours, theirs) = UnixStream::pair().unwrap_or_else(|e| panic!("{e}"));
    ours.write_all(line).unwrap_or_else(|e| panic!("{e}"));
    theirs
}

#[test]
fn a_request_is_one_bounded_utf8_line_within_the_deadline() {
    let mut s = client(b"status\nignored");
    assert_eq!(
        read_line(&mut s, Instant::now(), REQUEST_DEADLINE),
        Ok("status".into())
    );
    // Too long: refused as soon as the bound is passed, not read to its end.
    let (mut ours, mut theirs) = UnixStream::pair().unwrap_or_else(|e| panic!("{e}"));
    let writer = std::thread::spawn(move || {
        let chunk = vec![b'x'; 64 * 1024];
        for _ in 0..1600 {
            if ours.write_all(&chunk).is_err() {
                return;
            }
        }
    });
    let e = read_line(&mut theirs, Instant::now(), REQUEST_DEADLINE);
    assert_eq!(
        e,
        Err(format!("request line longer than {MAX_LINE_BYTES} bytes"))
    );
    drop(theirs);
    let _ = writer.join();
    let mut s = client(&[b's', 0xff, 0xfe, b'\n']);
    assert_eq!(
        read_line(&mut s, Instant::now(), REQUEST_DEADLINE),
        Err("request line is not UTF-8".into())
    );
    // A client that never ends its line (or sends a byte now and then) has the deadline
    // for the whole request, not for each byte.
    let (mut ours, mut theirs) = UnixStream::pair().unwrap_or_else(|e| panic!("{e}"));
    ours.write_all(b"sta").unwrap_or_else(|e| panic!("{e}"));
    let e = read_line(&mut theirs, Instant::now(), Duration::from_millis(50));
    assert_eq!(e, Err("no whole request line within 0.05 s".into()));
    let started = Instant::now() - Duration::from_secs(3);
    let mut s = client(b"status\n");
    assert!(read_line(&mut s, started, REQUEST_DEADLINE).is_err());
    // Closed without a line.
    drop(ours);
    let (a, mut b) = UnixStream::pair().unwrap_or_else(|e| panic!("{e}"));
    drop(a);
    assert_eq!(
        read_line(&mut b, Instant::now(), REQUEST_DEADLINE),
        Err("no request".into())
    );
}

#[test]
fn the_default_is_private_to_the_user() {
    let path = default_path();
    assert!(path.ends_with("vehicle.sock"), "{}", path.display());
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let name = dir.display().to_string();
    assert!(
        name.ends_with("/heli") || name.ends_with(&format!("heli-{}", effective_uid())),
        "{name}"
    );
}
