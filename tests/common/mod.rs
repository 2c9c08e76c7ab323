//! Robots for integration tests: the seed's cylindrical robot, a gantry and a SCARA, built in code.
#![allow(dead_code, unreachable_pub, missing_docs)]

pub mod cli;
pub mod console;
pub mod daemon;
pub mod exchange;
pub mod http;
pub mod moves;
pub mod places;
pub mod process;
pub mod serve;
pub mod served;

use linterpd::kinematics::{Cartesian, Elbow, JointKind, Model, Scara};
use linterpd::robot::{Joint, Method, Motion, OverSpeed, Robot, seed_robot};
use linterpd::table::{FrequencyModel, OutputMethod};

fn joint(
    name: &str,
    channel: u8,
    kind: JointKind,
    step_user: f64,
    limit_user: f64,
    max_freq_hz: u32,
) -> Joint {
    Joint {
        name: name.into(),
        channel,
        kind,
        step: kind.from_user(step_user),
        offset: 0.0,
        min: kind.from_user(-limit_user),
        max: kind.from_user(limit_user),
        max_freq_hz,
        output: OutputMethod::CwCcw,
        dynamics: linterpd::robot::Dynamics::default(),
    }
}

fn motion() -> Motion {
    Motion {
        method: Method::ConstantPeriod,
        period_s: 0.05,
        speed_mm_s: 200.0,
        accel_s: 0.2,
        frequency_model: FrequencyModel::FpxDivider,
        over_speed: OverSpeed::SlowDown,
        ramp: linterpd::robot::Ramp::Trapezoid,
    }
}

pub fn gantry() -> Robot {
    Robot {
        name: "gantry".into(),
        kinematics: Model::Cartesian(Cartesian).into(),
        joints: [
            joint("x", 0, JointKind::Prismatic, 0.01, 2_000.0, 100_000),
            joint("y", 1, JointKind::Prismatic, 0.01, 2_000.0, 100_000),
            joint("z", 2, JointKind::Prismatic, 0.02, 2_000.0, 20_000),
            joint("a", 3, JointKind::Revolute, 0.01, 720.0, 20_000),
        ],
        motion: motion(),
        area_words: 2_000,
        max_speed_mm_s: linterpd::robot::DEFAULT_MAX_SPEED_MM_S,
    }
}

pub fn scara() -> Robot {
    Robot {
        name: "scara".into(),
        kinematics: Model::Scara(Scara {
            l1_mm: 400.0,
            l2_mm: 300.0,
            elbow: Elbow::Left,
            reach_margin_mm: 1.0,
        })
        .into(),
        joints: [
            joint("t1", 0, JointKind::Revolute, 0.001, 360.0, 100_000),
            joint("t2", 1, JointKind::Revolute, 0.001, 360.0, 100_000),
            joint("z", 2, JointKind::Prismatic, 0.01, 1_000.0, 20_000),
            joint("wrist", 3, JointKind::Revolute, 0.005, 720.0, 20_000),
        ],
        motion: motion(),
        area_words: 2_000,
        max_speed_mm_s: linterpd::robot::DEFAULT_MAX_SPEED_MM_S,
    }
}

pub fn cylindrical() -> Robot {
    let mut r = seed_robot();
    r.motion.over_speed = OverSpeed::SlowDown;
    r
}

/// Runs `test` on a current-thread runtime with paused time and no I/O driver: what
/// `#[tokio::test(start_paused = true)]` gives, less the epoll the I/O driver makes at every
/// step of paused time (a quarter of the fault matrix's time went to the kernel). For tests
/// whose links are in memory.
///
/// # Panics
/// When the runtime cannot be built.
pub fn paused<F: std::future::Future>(test: F) -> F::Output {
    tokio::runtime::Builder::new_current_thread()
        .enable_time()
        .start_paused(true)
        .build()
        .expect("a runtime")
        .block_on(test)
}
