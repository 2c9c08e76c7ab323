//! One contract exchange against a mock PLC, the same over every link: check the PLC is alive,
//! plan the seed's move from the counts it reports, upload and verify a bank, start it, follow it
//! to done, and compare the final counts with the plan.
//!
//! The tests' driver of the pure [`Machine`] makes the daemon worker's exchanges in its order:
//! status reads until the PLC takes a start, the upload (begun in the machine first), then the
//! worker's own [`Contract::proof_read`] (the heartbeat word alone first, when the machine wants
//! two reads, then the status block) until [`Machine::may_start`], the start written once, and
//! status reads every poll interval to the start's end.

use linterpd::geometry::Pose;
use linterpd::kinematics::JOINTS;
use linterpd::mock::{MockConfig, MockPlc, SharedMock};
use linterpd::plan::{MoveRequest, Origin, Plan, plan_move};
use linterpd::plc::{Plc, PlcMode};
use std::time::Duration;

use linterpd::contract::machine::{Blocker, Event, Machine, Planned, Status};
use linterpd::plc::exchange::{
    CommandWrite, Contract, ContractError, ContractSettings, VerifiedBank, planned_bounds,
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

/// Reads the status block into `machine` (carrying out the host word and stop it asks for)
/// until a start can be written, as long as the heartbeat stands still no longer than its
/// limit: the heartbeat seen moving, the host word echoed, no fault, the ready bits set.
async fn until_ready<P: Plc>(
    c: &mut Contract<P>,
    machine: &mut Machine,
) -> Result<Status, ContractError> {
    let limit = machine.settings().heartbeat_timeout;
    let began = tokio::time::Instant::now();
    let mut first = None;
    loop {
        let status = c.status().await?;
        let now = tokio::time::Instant::now().into_std();
        for event in machine.on_status(&status, now) {
            carry_out(c, &event, machine).await?;
        }
        let moved = *first.get_or_insert(status.block.heartbeat) != status.block.heartbeat;
        let still = machine.heartbeat_age(now).unwrap_or_default();
        match machine.blocker(now) {
            None if moved => return Ok(status),
            Some(b @ (Blocker::Faulted { .. } | Blocker::NotReady { .. } | Blocker::NotHomed)) => {
                return Err(ContractError::Blocked(b));
            }
            _ if still > limit => return Err(stalled(c, still, limit).await),
            Some(b) if began.elapsed() > limit * 4 => return Err(ContractError::Blocked(b)),
            _ => tokio::time::sleep(c.settings().scan_time.min(limit / 4)).await,
        }
    }
}

/// Starts `bank`, uploaded for `start` (see [`upload`]), and follows it to its end: the start
/// is written only once the heartbeat is seen moving after the upload, the PLC takes a start
/// and every count is `start.from`. Done: the last status block; anything else: an error
/// ([`ContractError::Ended`] once the start was written).
pub async fn start_and_follow<P: Plc>(
    c: &mut Contract<P>,
    machine: &mut Machine,
    bank: &VerifiedBank,
    start: Planned,
) -> Result<Status, ContractError> {
    until_it_may_start(c, machine, &start).await?;
    let confirmed = matches!(c.start(bank).await?, CommandWrite::Confirmed);
    machine.start_written(
        start.clone(),
        tokio::time::Instant::now().into_std(),
        confirmed,
    );
    loop {
        tokio::time::sleep(c.settings().poll_interval).await;
        let status = c.status().await?;
        let now = tokio::time::Instant::now().into_std();
        let mut end = None;
        for event in machine.on_status(&status, now) {
            match event {
                Event::Done { tag, .. } if tag == start.tag => end = Some(Ok(status)),
                Event::Ended { tag, outcome } if tag == start.tag => {
                    end = Some(Err(ContractError::Ended {
                        seq: start.seq,
                        outcome,
                    }));
                }
                Event::RewriteStart { .. } => {
                    let confirmed = matches!(c.start(bank).await?, CommandWrite::Confirmed);
                    machine.start_rewritten(tokio::time::Instant::now().into_std(), confirmed);
                }
                other => carry_out(c, &other, machine).await?,
            }
        }
        if let Some(end) = end {
            return end;
        }
    }
}

/// After the upload of `start`: the daemon's reads toward the heartbeat proof
/// ([`Contract::proof_read`]) until the start may be written. Counts other than `start.from`, a
/// stalled PLC or anything else that blocks it end the upload with the reason.
async fn until_it_may_start<P: Plc>(
    c: &mut Contract<P>,
    machine: &mut Machine,
    start: &Planned,
) -> Result<(), ContractError> {
    loop {
        let status = c.proof_read(machine).await?;
        let now = tokio::time::Instant::now().into_std();
        for event in machine.on_status(&status, now) {
            carry_out(c, &event, machine).await?;
        }
        let blocker = match machine.may_start(start, now) {
            Ok(()) => return Ok(()),
            Err(Blocker::Unproven) => {
                tokio::time::sleep(c.settings().scan_time / 2).await;
                continue;
            }
            Err(blocker) => blocker,
        };
        machine.upload_ended();
        return Err(match blocker {
            Blocker::NotAtFrom {
                channel,
                count,
                from,
            } => ContractError::NotAtFrom {
                channel,
                count,
                from,
            },
            Blocker::Stalled => {
                let limit = machine.settings().heartbeat_timeout;
                let still = machine.heartbeat_age(now).unwrap_or_default();
                stalled(c, still, limit).await
            }
            other => ContractError::Blocked(other),
        });
    }
}

/// What the machine asks for that needs only the link: the host word, a stop.
async fn carry_out<P: Plc>(
    c: &mut Contract<P>,
    event: &Event,
    machine: &Machine,
) -> Result<(), ContractError> {
    match event {
        Event::WriteHost => c.write_host(machine.host()).await,
        Event::WriteStop => c.stop().await,
        _ => Ok(()),
    }
}

/// A stalled PLC, named with its mode when it says PROG.
async fn stalled<P: Plc>(c: &mut Contract<P>, still: Duration, limit: Duration) -> ContractError {
    let prog = matches!(c.plc().mode().await, Ok(PlcMode::Prog));
    ContractError::Stalled {
        still_ms: still.as_millis() as u64,
        limit_ms: limit.as_millis() as u64,
        mode: if prog { ", and in PROG mode" } else { "" },
    }
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
