//! A flight's ranking score: how far past (or how close to) its limits it came.

use heli_sim::summary::Criterion;

/// A ranking score at or above this is written as this: an unmeasured criterion, or a
/// ratio against a limit of zero.
pub const SCORE_CAP: f64 = 10.0;

/// A flight's ranking score and the criterion that gives it (see [`super::FlightRecord::score`]).
pub(crate) fn score(criteria: &[Criterion]) -> (f64, Option<String>) {
    let mut worst: Option<(f64, &str)> = None;
    // A passing at-least criterion (a flag such as plan_complete, the rolls, a hold as long
    // as its leg) shows that something was done; its distance from the limit is rarely a
    // margin, so it ranks nothing.
    for c in criteria
        .iter()
        .filter(|c| !(c.pass && c.value.is_some_and(|v| v >= c.limit)))
    {
        let r = ratio(c);
        if worst.is_none_or(|(s, _)| r > s) {
            worst = Some((r, c.name.as_str()));
        }
    }
    (
        worst.map_or(0.0, |(s, _)| s),
        worst.map(|(_, name)| name.to_string()),
    )
}

/// A criterion's ranking ratio: above 1 fails. The direction is read from the result: a
/// criterion that passes above its limit (or fails below it) is an at-least one.
pub(crate) fn ratio(c: &Criterion) -> f64 {
    let Some(v) = c.value.filter(|v| v.is_finite()) else {
        return SCORE_CAP;
    };
    let l = c.limit;
    let at_least = (c.pass && v > l) || (!c.pass && v < l);
    let r = if v == l {
        1.0
    } else if at_least {
        if v <= 0.0 { SCORE_CAP } else { l / v }
    } else if l <= 0.0 {
        SCORE_CAP
    } else {
        v / l
    };
    if r.is_nan() {
        SCORE_CAP
    } else {
        r.clamp(0.0, SCORE_CAP)
    }
}
