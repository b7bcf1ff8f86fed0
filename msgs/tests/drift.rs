//! Fails when the Rust types and the interface files drift apart.

use cnc_msgs::*;

mod common;
use common::{fields_of, parse, Pairs};

fn file(rel: &str) -> String {
    std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)).unwrap()
}

#[test]
fn run_program_srv_matches() {
    let text = file("srv/RunProgram.srv");
    let (req, resp) = text.split_once("\n---").expect("a service has a --- line");
    assert_eq!(parse(req).0, fields_of::<RunProgramRequest>());
    assert_eq!(parse(resp).0, fields_of::<RunProgramResponse>());
    assert_eq!(definitions::RUN_PROGRAM_SRV, text);
}

#[test]
fn set_delay_srv_matches() {
    let text = file("srv/SetDelay.srv");
    let (req, resp) = text.split_once("\n---").expect("a service has a --- line");
    assert_eq!(parse(req).0, fields_of::<SetDelayRequest>());
    assert_eq!(parse(resp).0, fields_of::<SetDelayResponse>());
    assert_eq!(definitions::SET_DELAY_SRV, text);
}

#[test]
fn spindle_encoder_msg_matches() {
    let text = file("msg/SpindleEncoder.msg");
    assert_eq!(parse(&text).0, fields_of::<SpindleEncoder>());
    assert_eq!(definitions::SPINDLE_ENCODER_MSG, text);
}

#[test]
fn controller_status_msg_matches() {
    let text = file("msg/ControllerStatus.msg");
    let (fields, consts) = parse(&text);
    assert_eq!(fields, fields_of::<ControllerStatus>());
    let want: Pairs = ControllerStatus::CONSTANTS
        .iter()
        .map(|(n, v)| (n.to_string(), v.to_string()))
        .collect();
    assert_eq!(consts, want);
    assert_eq!(definitions::CONTROLLER_STATUS_MSG, text);
}

#[test]
fn execute_program_action_matches() {
    let text = file("action/ExecuteProgram.action");
    let parts: Vec<&str> = text.split("\n---").collect();
    assert_eq!(parts.len(), 3, "an action has goal, result and feedback");
    assert_eq!(parse(parts[0]).0, fields_of::<ExecuteProgramGoal>());
    assert_eq!(parse(parts[1]).0, fields_of::<ExecuteProgramResult>());
    assert_eq!(parse(parts[2]).0, fields_of::<ExecuteProgramFeedback>());
    assert_eq!(definitions::EXECUTE_PROGRAM_ACTION, text);
    // the goal is the run_program request, line for line (comments too)
    let srv = file("srv/RunProgram.srv");
    let (req, _) = srv.split_once("\n---").expect("a service has a --- line");
    let goal: Vec<&str> = parts[0].lines().filter(|l| !l.starts_with('#')).collect();
    assert_eq!(goal, req.lines().collect::<Vec<_>>());
}

#[test]
fn the_package_builds_every_interface_file() {
    let cmake = file("CMakeLists.txt");
    for f in [
        "srv/RunProgram.srv",
        "srv/SetDelay.srv",
        "msg/SpindleEncoder.msg",
        "msg/ControllerStatus.msg",
        "action/ExecuteProgram.action",
    ] {
        assert!(
            cmake.contains(&format!("\"{f}\"")),
            "{f} missing from CMakeLists.txt"
        );
    }
    let mut on_disk: Vec<String> = ["action", "msg", "srv"]
        .iter()
        .flat_map(|d| {
            std::fs::read_dir(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(d))
                .unwrap()
                .map(move |e| format!("{d}/{}", e.unwrap().file_name().to_string_lossy()))
        })
        .collect();
    on_disk.sort();
    assert_eq!(
        on_disk,
        [
            "action/ExecuteProgram.action",
            "msg/ControllerStatus.msg",
            "msg/SpindleEncoder.msg",
            "srv/RunProgram.srv",
            "srv/SetDelay.srv"
        ]
    );
}
