use super::*;

fn fly(north_m: f64, east_m: f64, alt_m: f64, speed_mps: f64) -> Leg {
    Leg::Fly {
        north_m,
        east_m,
        alt_m,
        speed_mps,
    }
}

fn rolls(count: u32, speed_mps: f64) -> Leg {
    Leg::Rolls { count, speed_mps }
}

/// The leg alone as a plan: accepted, or the refusal's words.
fn judge(leg: Leg) -> Result<(), &'static str> {
    match Plan::new(&[leg]) {
        Ok(plan) => {
            assert_eq!(plan.get(0), Some(leg));
            Ok(())
        }
        Err(PlanError::BadValue(why)) => Err(why),
        Err(e) => panic!("{e}"),
    }
}

#[test]
fn take_off_heights_from_1_to_120_m() {
    for alt_m in [1.0, 60.0, 120.0] {
        assert_eq!(judge(Leg::Takeoff { alt_m }), Ok(()), "{alt_m}");
    }
    for alt_m in [0.99, 120.01, -5.0, f64::NAN, f64::INFINITY] {
        assert_eq!(
            judge(Leg::Takeoff { alt_m }),
            Err("take-off height must be 1-120 m"),
            "{alt_m}"
        );
    }
}

#[test]
fn holds_of_any_time_not_negative_and_without_end() {
    for seconds in [0.0, 1.5, f64::INFINITY] {
        assert_eq!(judge(Leg::Hold { seconds }), Ok(()), "{seconds}");
    }
    for seconds in [-0.01, f64::NAN, f64::NEG_INFINITY] {
        assert_eq!(
            judge(Leg::Hold { seconds }),
            Err("hold time must not be negative"),
            "{seconds}"
        );
    }
}

#[test]
fn paths_within_1_km_1_to_120_m_up_at_half_to_15_m_per_s() {
    let ok = [
        fly(1000.0, 0.0, 10.0, 3.0),
        fly(-1000.0, 0.0, 10.0, 3.0),
        fly(0.0, 1000.0, 10.0, 3.0),
        fly(0.0, -1000.0, 10.0, 3.0),
        fly(0.0, 0.0, 1.0, 3.0),
        fly(0.0, 0.0, 120.0, 3.0),
        fly(0.0, 0.0, 10.0, 0.5),
        fly(0.0, 0.0, 10.0, 15.0),
    ];
    for leg in ok {
        assert_eq!(judge(leg), Ok(()), "{leg:?}");
    }
    let refused = [
        fly(1000.1, 0.0, 10.0, 3.0),
        fly(-1000.1, 0.0, 10.0, 3.0),
        fly(0.0, 1000.1, 10.0, 3.0),
        fly(0.0, -1000.1, 10.0, 3.0),
        fly(0.0, 0.0, 0.99, 3.0),
        fly(0.0, 0.0, 120.01, 3.0),
        fly(0.0, 0.0, 10.0, 0.49),
        fly(0.0, 0.0, 10.0, 15.01),
        fly(f64::NAN, 0.0, 10.0, 3.0),
        fly(0.0, f64::NAN, 10.0, 3.0),
    ];
    for leg in refused {
        assert_eq!(
            judge(leg),
            Err("fly: within 1 km, 1-120 m up, 0.5-15 m/s"),
            "{leg:?}"
        );
    }
}

#[test]
fn one_to_ten_rolls_from_3_to_15_m_per_s() {
    for leg in [rolls(1, 8.0), rolls(10, 8.0), rolls(3, 3.0), rolls(3, 15.0)] {
        assert_eq!(judge(leg), Ok(()), "{leg:?}");
    }
    for leg in [
        rolls(0, 8.0),
        rolls(11, 8.0),
        rolls(3, 2.99),
        rolls(3, 15.01),
        rolls(3, f64::NAN),
    ] {
        assert_eq!(
            judge(leg),
            Err("rolls: 1-10 of them, from 3-15 m/s"),
            "{leg:?}"
        );
    }
}

#[test]
fn nothing_follows_a_landing() {
    let takeoff = Leg::Takeoff { alt_m: 5.0 };
    let hold = Leg::Hold { seconds: 1.0 };
    assert!(Plan::new(&[takeoff, hold, Leg::Land]).is_ok());
    assert_eq!(
        Plan::new(&[takeoff, Leg::Land, hold]),
        Err(PlanError::BadValue("nothing can follow a landing"))
    );
    assert_eq!(
        Plan::new(&[Leg::Land, Leg::Land]),
        Err(PlanError::BadValue("nothing can follow a landing"))
    );
}

#[test]
fn at_most_twelve_legs() {
    let hold = Leg::Hold { seconds: 1.0 };
    let full = Plan::new(&[hold; MAX_LEGS]).unwrap();
    assert_eq!(full.legs().count(), MAX_LEGS);
    assert_eq!(full.get(MAX_LEGS - 1), Some(hold));
    assert_eq!(full.get(MAX_LEGS), None);
    assert_eq!(
        Plan::new(&[hold; MAX_LEGS + 1]),
        Err(PlanError::TooManyLegs)
    );
    assert_eq!(
        PlanError::TooManyLegs.to_string(),
        "a plan has at most 12 legs"
    );
    assert_eq!(
        PlanError::BadValue("land").to_string(),
        "bad plan value: land"
    );
}

#[test]
fn a_plan_gives_its_legs_back_in_order() {
    let legs = [
        Leg::Takeoff { alt_m: 10.0 },
        rolls(3, 8.0),
        Leg::Hold { seconds: 2.0 },
        Leg::Land,
    ];
    let plan = Plan::new(&legs).unwrap();
    assert_eq!(plan.legs().collect::<Vec<_>>(), legs);
    assert_eq!(plan.get(3), Some(Leg::Land));
    assert_eq!(plan.get(4), None);
    assert_eq!(Plan::new(&[]).unwrap().legs().count(), 0);
    let hover = Plan::hover(10.0, 60.0);
    assert_eq!(hover.get(0), Some(Leg::Takeoff { alt_m: 10.0 }));
    assert_eq!(hover.get(1), Some(Leg::Hold { seconds: 60.0 }));
    assert_eq!(hover.get(2), None);
}

#[test]
fn legs_have_their_written_names() {
    let names: Vec<_> = [
        Leg::Takeoff { alt_m: 1.0 },
        Leg::Hold { seconds: 1.0 },
        fly(0.0, 0.0, 1.0, 1.0),
        rolls(1, 3.0),
        Leg::Land,
    ]
    .iter()
    .map(Leg::name)
    .collect();
    assert_eq!(names, ["takeoff", "hold", "fly", "rolls", "land"]);
}

#[cfg(feature = "serde")]
#[test]
fn legs_are_written_tagged_and_a_hold_without_end_is_null() {
    let legs = vec![
        Leg::Takeoff { alt_m: 10.0 },
        Leg::Hold {
            seconds: f64::INFINITY,
        },
        fly(40.0, -3.0, 10.0, 3.0),
        rolls(3, 8.0),
        Leg::Land,
    ];
    let json = serde_json::to_string(&legs).unwrap();
    assert_eq!(
        json,
        r#"[{"leg":"takeoff","alt_m":10.0},{"leg":"hold","seconds":null},{"leg":"fly","north_m":40.0,"east_m":-3.0,"alt_m":10.0,"speed_mps":3.0},{"leg":"rolls","count":3,"speed_mps":8.0},{"leg":"land"}]"#
    );
    let back: Vec<Leg> = serde_json::from_str(&json).unwrap();
    assert_eq!(back, legs);
    let err = serde_json::from_str::<Leg>(r#"{"leg":"takeoff","alt_m":3,"speed":1}"#).unwrap_err();
    assert!(err.to_string().contains("unknown field"), "{err}");
    assert!(serde_json::from_str::<Leg>(r#"{"leg":"hold"}"#).is_err());
    assert!(serde_json::from_str::<Leg>(r#"{"leg":"loop"}"#).is_err());
}
