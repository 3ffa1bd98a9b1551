//! `heli driver DEVICE`: one device's stand-alone driver (thesis §2.3): readable lines per
//! packet, the flight process's log format with `--log`.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use anyhow::{Context, Result, bail};
use heli_vehicle::standalone::{self, DriverKind, Source};

/// Which device.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum Device {
    /// The IMU (serial); runs the 12 ms watchdog and reports misses.
    Imu,
    /// The servo controller board (serial); passes the pilot's commands to the servos.
    Scb,
    /// The GPS receiver (serial).
    Gps,
    /// The barometric altimeter (serial); runs the handshake at --rate.
    Baro,
    /// The compass (ADC channels, --adc DIR).
    Compass,
    /// The battery (ADC channel, --adc DIR).
    Battery,
}

/// Arguments of `heli driver`.
#[derive(clap::Args)]
pub struct DriverArgs {
    /// The device.
    #[arg(value_enum)]
    pub device: Device,
    /// Serial port of the device (imu, scb, gps, baro).
    #[arg(long)]
    pub port: Option<PathBuf>,
    /// IIO directory of the ADC (compass, battery).
    #[arg(long)]
    pub adc: Option<PathBuf>,
    /// ADC channels: three for the compass (default 0,1,2), one for the battery (default 3).
    #[arg(long, value_delimiter = ',')]
    pub channel: Vec<u8>,
    /// Write a flight log (MCAP) of what the driver read.
    #[arg(long)]
    pub log: Option<PathBuf>,
    /// Altimeter readings per second (1-10).
    #[arg(long, default_value_t = heli_proto::baro::DEFAULT_RATE_HZ)]
    pub rate: u8,
    /// Stop after this many packets or readings.
    #[arg(long)]
    pub count: Option<u64>,
}

/// Runs the driver until --count, an error, or SIGINT / SIGTERM.
pub fn driver(args: &DriverArgs) -> Result<ExitCode> {
    if !(1..=10).contains(&args.rate) {
        bail!(
            "--rate {}: the altimeter does 1 to 10 readings a second",
            args.rate
        );
    }
    let kind = match args.device {
        Device::Imu => DriverKind::Imu,
        Device::Scb => DriverKind::Scb,
        Device::Gps => DriverKind::Gps,
        Device::Baro => DriverKind::Baro,
        Device::Compass => DriverKind::Compass,
        Device::Battery => DriverKind::Battery,
    };
    let source = match (kind, &args.port, &args.adc) {
        (DriverKind::Compass | DriverKind::Battery, _, Some(dir)) => Source::Adc {
            dir: dir.clone(),
            channels: match (kind, args.channel.is_empty()) {
                (DriverKind::Compass, true) => vec![0, 1, 2],
                (_, true) => vec![3],
                (_, false) => args.channel.clone(),
            },
        },
        (DriverKind::Compass | DriverKind::Battery, Some(port), None) => Source::Port(port.clone()),
        (DriverKind::Compass | DriverKind::Battery, None, None) => {
            bail!("give the ADC's IIO directory: --adc DIR")
        }
        (_, Some(port), _) => Source::Port(port.clone()),
        (_, None, _) => bail!("give the device's serial port: --port PATH"),
    };
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, Arc::clone(&stop))
            .context("installing the signal handler")?;
    }
    let mut print = |line: &str| println!("{line}");
    let report = standalone::run(
        kind,
        &source,
        args.log.as_deref(),
        args.rate,
        args.count,
        &stop,
        &mut print,
    )
    .map_err(anyhow::Error::msg)?;
    eprintln!(
        "heli driver: {} samples, {} watchdog misses, {} bytes discarded, {} servo packets, {} log messages",
        report.samples,
        report.watchdog_misses,
        report.discarded_bytes,
        report.servo_packets,
        report.log_messages
    );
    Ok(ExitCode::SUCCESS)
}
