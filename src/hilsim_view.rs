//! `heli hilsim --view ADDR`: the simulator's truth to the view's pages
//! (`heli_ground::truth_view`), with the scenario's flight plan.

use std::net::SocketAddr;
use std::time::Duration;

use anyhow::{Context, Result, anyhow};
use heli_ground::truth_view::{self, TruthFeed};
use heli_sim::Scenario;
use heli_sim::lockstep::Simulation;

/// How often a frame is taken from the simulation (wall clock): the pages get 30 a second.
pub const FRAME_EVERY: Duration = Duration::from_millis(30);

/// Serves the view for `scenario` on `addr` and prints its URL.
pub fn serve(addr: SocketAddr, scenario: &Scenario) -> Result<TruthFeed> {
    // The plan's legs as the vehicle reports them, into the points the display draws.
    let legs: Vec<heli_link::mission::PlanLeg> =
        serde_json::from_value(serde_json::to_value(&scenario.plan)?)
            .context("the scenario's plan as legs")?;
    let plan = heli_ground::view::plan_points(&heli_link::mission::mission_items(&legs));
    let setup = serde_json::json!({
        "type": "setup",
        "scenario": scenario.name,
        "plan": plan,
    });
    let (bound, feed) = truth_view::spawn(addr, setup.to_string()).map_err(|e| anyhow!(e))?;
    println!("hilsim: view http://{bound}/ (the simulator's truth)");
    Ok(feed)
}

/// Publishes the simulation's truth now.
pub fn publish(feed: &TruthFeed, sim: &Simulation) {
    let frame = sim.truth_frame();
    if let Ok(mut value) = serde_json::to_value(frame) {
        if let Some(map) = value.as_object_mut() {
            map.insert("type".into(), "truth".into());
        }
        feed.publish(value.to_string());
    }
}
