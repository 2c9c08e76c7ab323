//! One contract exchange against a mock PLC, the same over every link: check the PLC is alive,
//! plan the seed's move from the counts it reports, upload and verify a bank, start it, follow it
//! to done, and compare the final counts with the plan.
//!
//! The tests' driver of the pure [`Machine`] is the library's `plc::exchange::driver`, the one
//! the unit tests use too.

use linterpd::geometry::Pose;
use linterpd::kinematics::JOINTS;
use linterpd::mock::{MockConfig, MockPlc, SharedMock};
use linterpd::plan::{MoveRequest, Origin, Plan, plan_move};
use linterpd::plc::Plc;
use std::time::Duration;

use linterpd::contract::machine::{Machine, Planned};
pub use linterpd::plc::exchange::driver::start_and_follow;
use linterpd::plc::exchange::driver::until_ready;
use linterpd::plc::exchange::{
    Contract, ContractError, ContractSettings, VerifiedBank, planned_bounds,
};
use linterpd::robot::{Robot, seed_robot};

/// The seed's P1 and P2 (mm).
pub const P1: [f64; 3] = [-926.57, 535.03, 50.0];
pub const P2: [f64; 3] = [-1144.43, 659.60, 186.60];

/// A mock PLC in RUN whose channels stand at the seed's start counts (joint j on channel j).
pub fn mock_at_seed_start(script: &str) -> SharedMock {
    let robot = seed_robot();
    let mut mock = MockPlc::new(MockConfig::default()).unwrap();
    mock.set_faults(script.parse().unwrap());
    let start = robot.pose_with_wrist_at_zero(P1[0], P1[1], P1[2]).unwrap();
    let q = linterpd::kinematics::Kinematics::ik(&robot.kinematics, &start, None).unwrap();
    for (j, c) in robot.counts_of(&q).into_iter().enumerate() {
        mock.set_count(robot.joints[j].channel as usize, c);
    }
    let shared = SharedMock::new(mock);
    tokio::spawn(shared.clone().run_scans());
    shared
}

/// The seed's move, planned from where the PLC says the robot is.
pub fn plan_from(robot: &Robot, elapsed: [i32; 4]) -> Plan {
    let counts: [i64; JOINTS] =
        std::array::from_fn(|j| i64::from(elapsed[robot.joints[j].channel as usize]));
    let from = robot.pose_of(&counts);
    let to = Pose {
        a_rad: from.a_rad,
        ..Pose::from_mm_deg(P2[0], P2[1], P2[2], 0.0)
    };
    let req = MoveRequest {
        from: Origin::Counts(counts),
        to,
        motion: robot.motion,
    };
    plan_move(robot, &req).unwrap()
}

/// A machine for a test host.
pub fn machine() -> Machine {
    Machine::new(settings().watch, 0x7E57)
}

/// Checks the PLC (the host word written and echoed, the heartbeat moving), plans from its
/// counts, uploads into bank 0 with sequence `seq` (the machine told first, as the daemon does).
pub async fn upload<P: Plc>(
    c: &mut Contract<P>,
    m: &mut Machine,
    seq: u16,
) -> Result<(Plan, VerifiedBank, Planned), ContractError> {
    let robot = seed_robot();
    let status = until_ready(c, m).await?;
    let plan = plan_from(&robot, status.block.elapsed);
    let tables = plan.valid_tables(&robot).expect("a valid plan");
    let from = status.block.elapsed;
    m.upload_begun();
    let bank = match c.upload(0, seq, from, &tables).await {
        Ok(bank) => bank,
        Err(e) => {
            m.upload_ended();
            return Err(e);
        }
    };
    let segments: Vec<(usize, &[linterpd::table::Segment])> = plan
        .tables
        .iter()
        .map(|t| (usize::from(t.channel), t.segments.as_slice()))
        .collect();
    let (envelope, targets) = planned_bounds(from, &segments);
    let planned = Planned {
        tag: u64::from(seq),
        seq,
        bank: 0,
        from,
        targets: Some(targets),
        envelope,
        duration: Duration::from_secs_f64(plan.duration_s()),
        curve: None,
        permit: linterpd::contract::Permit::NONE,
    };
    Ok((plan, bank, planned))
}

/// The whole exchange: upload, start, follow to done, final counts equal the plan's.
pub async fn exchange<P: Plc>(c: &mut Contract<P>, seq: u16) -> Result<(), ContractError> {
    let mut m = machine();
    let (plan, bank, planned) = upload(c, &mut m, seq).await?;
    let done = start_and_follow(c, &mut m, &bank, planned).await?;
    let robot = seed_robot();
    let end = plan.end_counts();
    for (j, joint) in robot.joints.iter().enumerate() {
        assert_eq!(
            i64::from(done.block.elapsed[joint.channel as usize]),
            end[j],
            "joint {}",
            joint.name
        );
    }
    Ok(())
}

/// Homes every channel at the counts it holds (after a restart cleared the homed bit) and waits
/// for the homed bit.
pub async fn home_where_it_stands<P: Plc>(c: &mut Contract<P>) -> Result<(), ContractError> {
    // Once the PLC scans again (a command written before its first scan would be cleared).
    let first = c.status().await?.block.heartbeat;
    while c.status().await?.block.heartbeat == first {
        tokio::time::sleep(Duration::from_millis(2)).await;
    }
    let counts = c.status().await?.block.elapsed;
    c.home(0b1111, counts).await?;
    for _ in 0..200 {
        let s = c.status().await?;
        if s.block.ready & linterpd::contract::READY_HOMED != 0
            && s.state == linterpd::contract::State::Done
        {
            return Ok(());
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    panic!("the mock did not home within 2 s: {:?}", c.status().await);
}

/// Contract settings for tests: the defaults.
pub fn settings() -> ContractSettings {
    ContractSettings::default()
}
