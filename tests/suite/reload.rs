//! SIGHUP (`systemctl reload linterpd`) on a real `linterpd serve`: a changed gateway list and
//! cell are applied at once, a changed cell face is named as needing a restart, and a config
//! that does not load is refused with the running one kept (issue 47: every change was
//! "unchanged" but the robot's, its link's and `[daemon]`'s, and none was applied).

use crate::common;
use common::http::Endpoint;
use common::serve::READY;

const ROBOT: &str = "/v1/robots/press-loader";

async fn read_status(api: &Endpoint, address: &str) -> u16 {
    let path = format!("{ROBOT}/registers/{address}");
    api.call("GET", &path, None, None).await.status.as_u16()
}

/// What `POST .../cycles` of a program that is not there answers.
async fn run_nosuch(api: &Endpoint) -> String {
    let body = r#"{"program": "nosuch"}"#;
    let answer = api
        .call("POST", &format!("{ROBOT}/cycles"), Some(body), None)
        .await;
    answer.text()
}

#[tokio::test]
async fn sighup_applies_the_gateway_and_cell_names_the_face_for_a_restart_and_refuses_a_bad_file() {
    let gateway = "[robots.press-loader.gateway]\nread = [\"DT0-DT99\"]\n";
    let mut running = common::serve::start_with_config(&[], gateway);
    let api = Endpoint::unix(&running.socket);
    assert_eq!(
        read_status(&api, "DT500").await,
        403,
        "not in the read list"
    );
    assert!(run_nosuch(&api).await.contains("has no cycle programs"));

    let started = std::fs::read_to_string(&running.config).unwrap();
    let programs = running.config.parent().unwrap().join("cycles");
    std::fs::create_dir_all(&programs).unwrap();
    let changed = started.replace("DT0-DT99", "DT0-DT999")
        + "[robots.press-loader.cell]\nprograms = \"cycles\"\n\
           [robots.press-loader.cell.face]\nplc = \"DT20000\"\n";
    std::fs::write(&running.config, &changed).unwrap();
    running.serve.hangup();
    running
        .serve
        .wait_for_stderr("SIGHUP: applied [robots.press-loader.gateway] read", READY);
    running
        .serve
        .wait_for_stderr("SIGHUP: applied [robots.press-loader.cell] programs", READY);
    running.serve.wait_for_stderr(
        "SIGHUP: [robots.press-loader.cell.face] plc changed: needs a restart",
        READY,
    );
    assert_eq!(
        read_status(&api, "DT500").await,
        200,
        "the new list applies"
    );
    let answer = run_nosuch(&api).await;
    assert!(answer.contains("no such program"), "{answer}");
    assert!(!running.serve.output().contains("unchanged"));

    // A typo: refused with the file and the key, the running config kept.
    std::fs::write(&running.config, changed.replace("programs =", "programz =")).unwrap();
    running.serve.hangup();
    running
        .serve
        .wait_for_stderr("SIGHUP: the config is refused", READY);
    running.serve.wait_for_stderr("programz", READY);
    assert_eq!(
        read_status(&api, "DT500").await,
        200,
        "still the list that ran"
    );
    assert!(run_nosuch(&api).await.contains("no such program"));

    let status = running.serve.terminate(READY);
    assert!(status.success(), "{status:?}");
}
