//! `heli link keygen`, and what the vehicle and the ground share about the link: the
//! `udp:HOST:PORT` address form and the signing key file.

use std::io::Read;
use std::net::{SocketAddr, ToSocketAddrs};
use std::path::Path;
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use heli_link::signing::Key;

/// The address of `udp:HOST:PORT`.
pub fn parse_link(text: &str) -> Result<SocketAddr> {
    let Some(rest) = text.strip_prefix("udp:") else {
        bail!("link '{text}': expected udp:HOST:PORT (e.g. udp:127.0.0.1:14550)");
    };
    rest.to_socket_addrs()
        .with_context(|| format!("link '{text}': expected udp:HOST:PORT"))?
        .next()
        .with_context(|| format!("link '{text}': no address"))
}

/// The key in `path`, or none without a path.
pub fn load_key(path: Option<&Path>) -> Result<Option<Key>> {
    let Some(path) = path else { return Ok(None) };
    let text = std::fs::read_to_string(path).with_context(|| {
        format!(
            "signing key {} (make one with heli link keygen)",
            path.display()
        )
    })?;
    Key::from_text(&text)
        .map(Some)
        .with_context(|| format!("signing key {}", path.display()))
}

/// `heli link keygen --out FILE`: a new random key, written readable by its owner only.
pub fn keygen(out: &Path, force: bool) -> Result<ExitCode> {
    if out.exists() && !force {
        bail!(
            "{} exists: a key already made is kept (--force replaces it, and every side must then get the new one)",
            out.display()
        );
    }
    let mut bytes = [0u8; 32];
    std::fs::File::open("/dev/urandom")
        .and_then(|mut f| f.read_exact(&mut bytes))
        .context("reading /dev/urandom")?;
    let key = Key::new(bytes);
    write_private(out, &key.to_text())?;
    println!(
        "wrote {}: give the same file to the vehicle (heli vehicle --key) and the ground (heli ground --key)",
        out.display()
    );
    Ok(ExitCode::SUCCESS)
}

fn write_private(path: &Path, text: &str) -> Result<()> {
    use std::io::Write;
    use std::os::unix::fs::OpenOptionsExt;
    let mut file = std::fs::OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(true)
        .mode(0o600)
        .open(path)
        .with_context(|| format!("writing {}", path.display()))?;
    // `mode` applies only to a file created here: an old key file replaced with --force
    // gets the same permissions.
    use std::os::unix::fs::PermissionsExt;
    file.set_permissions(std::fs::Permissions::from_mode(0o600))
        .with_context(|| format!("setting the permissions of {}", path.display()))?;
    file.write_all(text.as_bytes())
        .with_context(|| format!("writing {}", path.display()))
}
