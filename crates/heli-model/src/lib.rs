//! The X-Cell 60 miniature helicopter as a nonlinear model (Gavrilets, Mettler and Feron,
//! 2001): its parameters ([`params`]), the main and tail rotors ([`rotor`]), the fuselage and
//! empennage ([`empennage`]), the skids on the ground ([`ground`]), the whole rigid body and
//! its integration ([`model`]), the servos and the governor between the servo board and the
//! rotor ([`actuators`]), Dryden turbulence ([`turbulence`]), seeded noise ([`noise`]) and the
//! analyses of `heli model` — trim, modes, the governor's step ([`analysis`]).
//!
//! What it is not: devices, scenarios or flight software. It knows nothing of bytes or of the
//! flight computer; `heli-sim` puts it behind simulated devices.

pub mod actuators;
pub mod analysis;
pub mod empennage;
pub mod ground;
pub mod model;
pub mod noise;
pub mod params;
pub mod rotor;
pub mod turbulence;
