//! The mock PLC against CONTRACT.md's program and ACCURACY.md's execution model.

use std::sync::Arc;

use super::*;
use crate::contract::{CommandBlock, Fault, State};
use crate::table::{Direction, FrequencyRange, Segment};

const SCAN: f64 = DEFAULT_SCAN_S;

fn mock(model: FrequencyModel) -> MockPlc {
    let mut m = MockPlc::new(MockConfig {
        model,
        ..MockConfig::default()
    })
    .unwrap();
    m.record_pulses(true);
    m
}

use crate::table::pulse_sign_segment as seg;

fn up(rows: &[(u32, i64)]) -> Segment {
    seg(Direction::Up, FrequencyRange::High, rows)
}

/// The area image of any segments, valid or not (`table::encode` only takes valid tables).
fn image(segments: &[Segment]) -> Vec<u16> {
    let mut w = vec![0u16; 8];
    let dint = |w: &mut Vec<u16>, v: u32| w.extend([(v & 0xFFFF) as u16, (v >> 16) as u16]);
    for (i, s) in segments.iter().enumerate() {
        w[i] = w.len() as u16;
        dint(&mut w, s.control.value());
        for r in &s.rows {
            dint(&mut w, r.freq_hz);
            dint(&mut w, r.target as i32 as u32);
        }
        dint(&mut w, 0);
    }
    w
}

/// Writes the channels' areas of `bank`, then the command block with `command = 1` and `from`
/// the counts the channels hold now.
fn start(m: &mut MockPlc, bank: u16, seq: u16, channels: &[(usize, Vec<Segment>)]) {
    let from = std::array::from_fn(|c| m.count(c) as i32);
    start_from(m, bank, seq, from, channels);
}

fn start_from(
    m: &mut MockPlc,
    bank: u16,
    seq: u16,
    from: [i32; 4],
    channels: &[(usize, Vec<Segment>)],
) {
    let layout = m.config().layout;
    let mut block = CommandBlock {
        command: 1,
        seq,
        bank,
        from,
        ..CommandBlock::default()
    };
    for (c, segments) in channels {
        m.write_words(u32::from(layout.area(bank, *c)), &image(segments))
            .unwrap();
        block.mask |= 1 << c;
        block.segments[*c] = segments.len() as u16;
    }
    write_block(m, block);
}

/// Writes the command block as a host does: words 1..16 (not the host word), then the command.
fn write_block(m: &mut MockPlc, block: CommandBlock) {
    let base = u32::from(m.config().layout.command_base);
    let host = usize::from(crate::contract::COMMAND_HOST_OFFSET);
    m.write_words(base + 1, &block.to_words()[1..host]).unwrap();
    m.write_words(base, &[block.command]).unwrap();
}

fn command_word(m: &MockPlc) -> u16 {
    m.read_words(u32::from(m.config().layout.command_base), 1)
        .unwrap()[0]
}

fn write_command(m: &mut MockPlc, command: u16) {
    let base = u32::from(m.config().layout.command_base);
    m.write_words(base, &[command]).unwrap();
}

fn times(pulses: &[PulsePoint], channel: u8) -> Vec<f64> {
    pulses
        .iter()
        .filter(|p| p.channel == channel)
        .map(|p| p.time_s)
        .collect()
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-9
}

#[test]
fn heartbeat_counts_scans_and_freezes_on_request() {
    let mut m = mock(FrequencyModel::Ideal);
    m.advance_to(9.0 * SCAN);
    let s = m.status();
    assert_eq!(
        (s.magic, s.version, s.heartbeat),
        (crate::contract::MAGIC, 3, 10)
    );
    assert_eq!(s.ready, 0b111);
    m.set_faults("freeze@t=0.05".parse().unwrap());
    m.advance_to(0.1);
    assert_eq!(
        m.status().heartbeat,
        25,
        "scans before 50 ms count, the rest do not"
    );
    m.freeze_heartbeat(false);
    m.advance_to(0.1 + SCAN);
    assert_eq!(m.status().heartbeat, 26, "counting again");
}

#[test]
fn prog_mode_stops_the_program_and_its_heartbeat() {
    let mut m = mock(FrequencyModel::Ideal);
    start(&mut m, 0, 1, &[(0, vec![up(&[(1_000, 1_000)])])]);
    m.advance_to(0.1);
    let before = m.status();
    assert!(before.busy & 1 == 1);
    m.set_faults("prog@2".parse().unwrap());
    assert!(m.on_command().is_empty());
    assert_eq!(m.mode(), PlcMode::Run);
    m.on_command();
    assert_eq!(m.mode(), PlcMode::Prog);
    let count = m.count(0);
    m.advance_to(0.5);
    assert_eq!(
        m.status(),
        before,
        "nothing in the status block moves in PROG"
    );
    assert_eq!(m.count(0), count, "pulse output stops in PROG");
    m.set_mode(PlcMode::Run);
    m.advance_to(0.5 + SCAN);
    // Back in RUN the program starts with a first scan: idle, seq 0, host 0, not homed.
    let after = m.status();
    assert_eq!(
        (after.state, after.seq, after.host, after.ready & 1),
        (State::Idle.word(), 0, 0, 0)
    );
    assert_eq!(after.heartbeat, before.heartbeat + 1);
}

fn seed_plan() -> crate::plan::Plan {
    use crate::geometry::Pose;
    use crate::plan::{MoveRequest, Origin, plan_move};
    let robot = crate::robot::seed_robot();
    let from = robot
        .pose_with_wrist_at_zero(-926.57, 535.03, 50.0)
        .unwrap();
    let mut to = Pose::from_mm_deg(-1144.43, 659.60, 186.60, 0.0);
    to.a_rad = from.a_rad;
    let motion = crate::robot::Motion {
        frequency_model: FrequencyModel::FpxDivider,
        ..robot.motion
    };
    plan_move(
        &robot,
        &MoveRequest {
            from: Origin::Pose(from),
            to,
            motion,
        },
    )
    .unwrap()
}

#[test]
fn seed_move_gives_exactly_the_execution_models_pulses() {
    let robot = crate::robot::seed_robot();
    let plan = seed_plan();
    let tables = plan.valid_tables(&robot).unwrap();
    assert!(
        tables.iter().all(|t| t.table().segments.len() == 1),
        "a single-segment plan"
    );
    let mut m = mock(FrequencyModel::FpxDivider);
    let layout = m.config().layout;
    let mut block = CommandBlock {
        command: 1,
        seq: 5,
        ..CommandBlock::default()
    };
    for t in &tables {
        let c = usize::from(t.table().channel);
        m.set_count(c, t.table().start);
        block.from[c] = t.table().start as i32;
        m.write_words(u32::from(layout.area(0, c)), &crate::table::encode(t))
            .unwrap();
        block.mask |= 1 << c;
        block.segments[c] = 1;
    }
    m.advance_to(0.001);
    write_block(&mut m, block);
    let start_s = SCAN; // the first scan after the write
    m.advance_to(plan.duration_s() + 0.1);
    assert_eq!(m.state(), State::Done);
    assert_eq!(m.status().seq, 5);
    let mut pulses = m.take_pulses();
    pulses.sort_by(|a, b| {
        a.time_s
            .total_cmp(&b.time_s)
            .then(a.channel.cmp(&b.channel))
    });
    let execution = plan.execution();
    let events = &execution.events;
    assert_eq!(pulses.len(), events.len());
    for (p, e) in pulses.iter().zip(events) {
        assert_eq!(usize::from(p.channel), e.table);
        assert_eq!(p.count, e.count);
        assert!(close(p.time_s, start_s + e.t_s), "{p:?} vs {e:?}");
    }
    assert_eq!(m.status().elapsed.map(i64::from), plan.end_counts());
}

#[test]
fn next_segment_starts_in_the_first_scan_after_the_previous_ends() {
    let mut m = mock(FrequencyModel::Ideal);
    let down = seg(Direction::Down, FrequencyRange::High, &[(1_000, 1)]);
    start(&mut m, 0, 1, &[(0, vec![up(&[(1_000, 3)]), down])]);
    m.advance_to(0.1);
    let t = times(&m.take_pulses(), 0);
    // Started at the scan at 2 ms (the first after the write): segment 1 ends at 5 ms, the
    // next scan is at 6 ms.
    assert_eq!(t.len(), 5);
    assert!(
        close(t[2], 0.005) && close(t[3], 0.007) && close(t[4], 0.008),
        "{t:?}"
    );
    assert_eq!(m.count(0), 1);
    assert_eq!(m.status().segment[0], 2);
    assert_eq!(m.state(), State::Done);
}

#[test]
fn start_while_running_waits_and_runs_right_after_done() {
    let mut m = mock(FrequencyModel::Ideal);
    start(&mut m, 0, 1, &[(0, vec![up(&[(1_000, 9)])])]);
    m.advance_to(0.005);
    start_from(&mut m, 1, 2, [9, 0, 0, 0], &[(0, vec![up(&[(1_000, 12)])])]);
    m.advance_to(0.0105);
    assert_eq!(command_word(&m), 1, "the start waits while running");
    assert_eq!(m.status().seq, 1);
    m.advance_to(0.1);
    let t = times(&m.take_pulses(), 0);
    // Move 1 starts at 2 ms and ends at 11 ms; the 12 ms scan sees it done; the 14 ms scan
    // starts move 2.
    assert!(close(t[8], 0.011) && close(t[9], 0.015), "{t:?}");
    assert_eq!(
        (m.status().seq, m.state(), m.count(0)),
        (2, State::Done, 12)
    );
    assert_eq!(command_word(&m), 0);
    // The record says when each start was first seen: move 2 at the 6 ms scan, waiting.
    let starts = m.starts();
    assert!(close(starts[0].seen_s, starts[0].at_s), "{starts:?}");
    assert!(
        close(starts[1].seen_s, 0.006) && close(starts[1].at_s, 0.014),
        "{starts:?}"
    );
}

#[test]
fn stop_halts_every_channel() {
    let mut m = mock(FrequencyModel::Ideal);
    start(
        &mut m,
        0,
        1,
        &[(0, vec![up(&[(1_000, 100)])]), (3, vec![up(&[(500, 100)])])],
    );
    m.advance_to(0.021);
    write_command(&mut m, 2);
    m.advance_to(0.022);
    let counts = (m.count(0), m.count(3));
    assert!(
        (20..=21).contains(&counts.0) && (10..=11).contains(&counts.1),
        "{counts:?}"
    );
    m.advance_to(0.5);
    assert_eq!((m.count(0), m.count(3)), counts);
    let s = m.status();
    assert_eq!((s.state, s.fault, s.busy), (State::Stopped.word(), 0, 0));
    assert_eq!(command_word(&m), 0);
}

#[test]
fn estop_input_stops_everything_clears_a_waiting_start_and_latches_fault_three() {
    let mut m = mock(FrequencyModel::Ideal);
    start(&mut m, 0, 1, &[(1, vec![up(&[(1_000, 100)])])]);
    m.advance_to(0.011);
    start(&mut m, 1, 2, &[(1, vec![up(&[(1_000, 200)])])]);
    m.set_estop_open(true);
    m.advance_to(0.012);
    let count = m.count(1);
    m.set_estop_open(false);
    m.advance_to(0.5);
    assert_eq!(m.count(1), count);
    assert_eq!(command_word(&m), 0, "the waiting start is gone");
    let s = m.status();
    assert_eq!(
        (s.state, s.fault, s.seq),
        (State::Stopped.word(), Fault::StoppedFromOutside.word(), 1)
    );
}

#[test]
fn estop_open_drops_ready_bit_two() {
    let mut m = mock(FrequencyModel::Ideal);
    m.set_ready(0b011);
    m.advance_to(SCAN);
    assert_eq!(m.status().ready, 0b011);
    m.set_ready(0b111);
    m.set_estop_open(true);
    m.advance_to(SCAN);
    assert_eq!(m.status().ready, 0b011);
}

type Setup = Box<dyn Fn(&mut MockPlc)>;

#[test]
fn bad_command_block_latches_fault_one() {
    let good = || vec![up(&[(1_000, 5)])];
    let cases: Vec<(&str, Setup)> = vec![
        (
            "no channel",
            Box::new(|m| {
                write_block(
                    m,
                    CommandBlock {
                        command: 1,
                        seq: 3,
                        ..CommandBlock::default()
                    },
                );
            }),
        ),
        (
            "bank 2",
            Box::new(move |m| {
                start(m, 0, 1, &[(0, good())]);
                m.write_words(1_035, &[2]).unwrap();
            }),
        ),
        (
            "9 segments",
            Box::new(move |m| {
                start(m, 0, 1, &[(0, good())]);
                m.write_words(1_036, &[9]).unwrap();
            }),
        ),
        (
            "area without segment 2",
            Box::new(move |m| {
                start(m, 0, 1, &[(0, good())]);
                m.write_words(1_036, &[2]).unwrap();
            }),
        ),
        (
            "masked channel with 0 segments",
            Box::new(|m| {
                write_block(
                    m,
                    CommandBlock {
                        command: 1,
                        seq: 3,
                        mask: 0b10,
                        ..CommandBlock::default()
                    },
                );
            }),
        ),
    ];
    for (name, setup) in cases {
        let mut m = mock(FrequencyModel::Ideal);
        setup(&mut m);
        m.advance_to(0.1);
        let s = m.status();
        assert_eq!(
            (s.state, s.fault),
            (State::Fault.word(), Fault::BadTableHeader.word()),
            "{name}"
        );
        assert_eq!(command_word(&m), 0, "{name}");
        assert!(m.take_pulses().is_empty(), "{name}");
        assert!(m.last_fault().is_some(), "{name}");
    }
}

#[test]
fn fault_state_ignores_start_until_cleared() {
    let mut m = mock(FrequencyModel::Ideal);
    write_block(
        &mut m,
        CommandBlock {
            command: 1,
            seq: 3,
            ..CommandBlock::default()
        },
    );
    m.advance_to(0.01);
    start(&mut m, 0, 7, &[(0, vec![up(&[(1_000, 5)])])]);
    m.advance_to(0.02);
    assert_eq!(
        (m.state(), command_word(&m), m.count(0)),
        (State::Fault, 0, 0)
    );
    write_command(&mut m, 3);
    m.advance_to(0.03);
    assert_eq!(
        (m.status().state, m.status().fault),
        (State::Idle.word(), 0)
    );
    start(&mut m, 0, 7, &[(0, vec![up(&[(1_000, 5)])])]);
    m.advance_to(0.1);
    assert_eq!((m.state(), m.count(0), m.status().seq), (State::Done, 5, 7));
}

#[test]
fn busy_channel_at_start_latches_fault_two() {
    let mut m = mock(FrequencyModel::Ideal);
    // Channel 1's second segment starts below range 2's 191 Hz: fault 4 at chaining, while
    // channel 0 keeps running.
    let bad_second = up(&[(100, 10)]);
    start(
        &mut m,
        0,
        1,
        &[
            (0, vec![up(&[(1_000, 1_000)])]),
            (1, vec![up(&[(1_000, 3)]), bad_second]),
        ],
    );
    m.advance_to(0.02);
    assert_eq!(
        (m.status().state, m.status().fault),
        (State::Fault.word(), Fault::PulseInstruction.word())
    );
    assert!(m.busy(0));
    write_command(&mut m, 3);
    m.advance_to(0.03);
    assert_eq!(m.state(), State::Idle);
    start(&mut m, 1, 2, &[(0, vec![up(&[(1_000, 2_000)])])]);
    m.advance_to(0.04);
    assert_eq!(
        (m.status().state, m.status().fault),
        (State::Fault.word(), Fault::ChannelBusy.word())
    );
}

#[test]
fn first_frequency_out_of_range_latches_fault_four_and_outputs_nothing() {
    let mut m = mock(FrequencyModel::Ideal);
    // Channel 2 allows 20 kHz.
    start(
        &mut m,
        0,
        1,
        &[
            (0, vec![up(&[(1_000, 50)])]),
            (2, vec![up(&[(25_000, 50)])]),
        ],
    );
    m.advance_to(0.5);
    let s = m.status();
    assert_eq!(
        (s.state, s.fault, s.seq),
        (State::Fault.word(), Fault::PulseInstruction.word(), 0)
    );
    assert!(m.take_pulses().is_empty());
    assert!(
        m.last_fault().unwrap().contains("25000 Hz"),
        "{:?}",
        m.last_fault()
    );
}

#[test]
fn incremental_targets_are_a_pulse_instruction_error() {
    let mut m = mock(FrequencyModel::Ideal);
    let mut s = up(&[(1_000, 50)]);
    s.control.absolute = false;
    start(&mut m, 0, 1, &[(0, vec![s])]);
    m.advance_to(0.1);
    assert_eq!(m.status().fault, Fault::PulseInstruction.word());
}

#[test]
fn later_out_of_range_frequency_is_clamped_and_flagged() {
    let mut m = mock(FrequencyModel::Ideal);
    start(&mut m, 0, 1, &[(2, vec![up(&[(1_000, 2), (30_000, 4)])])]);
    m.advance_to(0.1);
    let t = times(&m.take_pulses(), 2);
    assert!(
        close(t[3] - t[2], 1.0 / 20_000.0),
        "runs at the channel's 20 kHz: {t:?}"
    );
    assert_eq!(m.state(), State::Done);
    assert!(matches!(
        m.anomalies(),
        [Anomaly::Clamped {
            channel: 2,
            segment: 1,
            row: 2,
            freq_hz: 30_000,
            max_hz: 20_000,
            ..
        }]
    ));
}

#[test]
fn first_frequency_zero_outputs_nothing_and_finishes() {
    let mut m = mock(FrequencyModel::Ideal);
    start(&mut m, 0, 1, &[(0, vec![up(&[])])]);
    m.advance_to(0.1);
    assert_eq!((m.state(), m.count(0)), (State::Done, 0));
}

#[test]
fn target_against_the_direction_runs_on_without_end_until_stop() {
    let mut m = mock(FrequencyModel::Ideal);
    start(&mut m, 0, 1, &[(0, vec![up(&[(1_000, 5), (1_000, 3)])])]);
    m.advance_to(1.0);
    assert!(m.count(0) > 900, "{}", m.count(0));
    assert!(m.running_on(0));
    assert_eq!(m.state(), State::Running, "a run-on never finishes");
    let elapsed = m.status().elapsed[0];
    m.advance_to(2.0);
    assert!(m.status().elapsed[0] > elapsed + 900);
    assert!(matches!(
        m.anomalies(),
        [Anomaly::RunOn {
            from: 5,
            target: 3,
            ..
        }]
    ));
    write_command(&mut m, 2);
    m.advance_to(2.0 + SCAN);
    let count = m.count(0);
    m.advance_to(3.0);
    assert_eq!(m.count(0), count);
    assert!(!m.running_on(0));
}

#[test]
fn elapsed_and_busy_in_the_status_block_match_the_engines_at_every_scan() {
    let mut m = mock(FrequencyModel::FpxDivider);
    m.set_count(1, -40);
    let down = seg(
        Direction::Down,
        FrequencyRange::Mid,
        &[(3_000, -70), (700, -90)],
    );
    start(
        &mut m,
        0,
        1,
        &[(0, vec![up(&[(2_345, 60)])]), (1, vec![down])],
    );
    for k in 1..60 {
        m.advance_to(f64::from(k) * SCAN);
        let s = m.status();
        for c in 0..2 {
            assert_eq!(i64::from(s.elapsed[c]), m.count(c), "scan {k} channel {c}");
            assert_eq!(s.busy >> c & 1 == 1, m.busy(c), "scan {k} channel {c}");
        }
    }
    assert_eq!((m.count(0), m.count(1)), (60, -90));
}

#[test]
fn on_command_hands_link_faults_to_the_server_in_order() {
    let mut m = mock(FrequencyModel::Ideal);
    m.set_faults("drop@1,error61@2,delay30@2,close@3".parse().unwrap());
    assert_eq!(m.on_command(), vec![LinkFault::Drop]);
    assert_eq!(
        m.on_command(),
        vec![
            LinkFault::MewtocolError { code: 61 },
            LinkFault::Delay { ms: 30 }
        ]
    );
    assert_eq!(m.on_command(), vec![LinkFault::Close]);
    assert!(m.on_command().is_empty());
    assert_eq!(m.commands(), 4);
}

#[test]
fn pulse_trace_writes_csv() {
    let mut m = mock(FrequencyModel::Ideal);
    start(&mut m, 0, 1, &[(0, vec![up(&[(1_000, 2)])])]);
    m.advance_to(0.1);
    let mut out = Vec::new();
    write_csv(&m.take_pulses(), &mut out).unwrap();
    assert_eq!(
        String::from_utf8(out).unwrap(),
        "time_s,channel,count\n0.003000000,0,1\n0.004000000,0,2\n"
    );
}

#[test]
fn in_process_handle_runs_a_move_through_the_plc_trait() {
    use crate::plc::Plc;
    let shared = Arc::new(std::sync::Mutex::new(mock(FrequencyModel::Ideal)));
    let mut plc = InProcess::new(shared.clone());
    let rt = tokio::runtime::Builder::new_current_thread()
        .build()
        .unwrap();
    rt.block_on(async {
        assert_eq!(plc.mode().await.unwrap(), PlcMode::Run);
        plc.write_words(2_000, &image(&[up(&[(1_000, 20)])]))
            .await
            .unwrap();
        let block = CommandBlock {
            command: 0,
            seq: 9,
            mask: 1,
            bank: 0,
            segments: [1, 0, 0, 0],
            from: [0; 4],
            host: 0,
            permit: crate::contract::Permit::NONE,
        };
        plc.write_words(1_033, &block.to_words()[1..])
            .await
            .unwrap();
        plc.write_words(1_032, &[1]).await.unwrap();
        let mut status = StatusBlock::default();
        for _ in 0..100 {
            let words = plc.read_words(1_000, crate::contract::STATUS_WORDS as u16);
            status = StatusBlock::from_words(&words.await.unwrap()).unwrap();
            if status.state == State::Done.word() {
                break;
            }
        }
        assert_eq!((status.seq, status.elapsed[0]), (9, 20));
        plc.write_relay(0x2A, true).await.unwrap();
        assert!(plc.read_relay(0x2A).await.unwrap());
        let err = plc.read_words(32_760, 10).await.unwrap_err();
        assert!(err.to_string().contains("error 61"), "{err}");
    });
    assert!(plc.now_s() > 0.02);
    plc.advance(1.0);
    assert!(shared.lock().unwrap().now_s() > 1.0);
}

#[test]
fn mock_can_be_shared_between_server_tasks() {
    fn shareable<T: Send + 'static>() {}
    shareable::<Arc<std::sync::Mutex<MockPlc>>>();
    shareable::<InProcess>();
}

#[test]
fn in_process_mode_reports_prog_after_a_scripted_switch() {
    use crate::plc::Plc;
    let mut m = mock(FrequencyModel::Ideal);
    m.set_faults("prog@t=0.01".parse().unwrap());
    let mut plc = InProcess::new(Arc::new(std::sync::Mutex::new(m))).with_exchange_s(0.02);
    let rt = tokio::runtime::Builder::new_current_thread()
        .build()
        .unwrap();
    assert_eq!(rt.block_on(plc.mode()).unwrap(), PlcMode::Prog);
}

// ---------------------------------------------------------------------------------------------
// Contract version 2: from, repeated seq, waiting, host word, homing, restarts

fn outcomes(m: &MockPlc) -> Vec<(u16, StartOutcome)> {
    m.starts()
        .iter()
        .map(|r| (r.block.seq, r.outcome))
        .collect()
}

#[test]
fn a_start_from_other_counts_is_refused_with_fault_five_and_nothing_moves() {
    let mut m = mock(FrequencyModel::Ideal);
    m.set_count(2, 7);
    start_from(&mut m, 0, 1, [0; 4], &[(0, vec![up(&[(1_000, 50)])])]);
    m.advance_to(0.1);
    let s = m.status();
    assert_eq!(
        (s.state, s.fault, s.seq),
        (State::Fault.word(), Fault::NotAtStart.word(), 0),
        "channel 2 is not in the mask but is checked all the same"
    );
    assert!(m.take_pulses().is_empty());
    assert!(m.last_fault().unwrap().contains("channel 2 is at 7"));
    let record = m.starts()[0];
    assert_eq!(record.outcome, StartOutcome::Refused(Fault::NotAtStart));
    assert!(record.from_mismatch());
}

#[test]
fn a_repeated_start_runs_once() {
    let mut m = mock(FrequencyModel::Ideal);
    start(&mut m, 0, 4, &[(0, vec![up(&[(1_000, 10)])])]);
    m.advance_to(0.05);
    assert_eq!((m.state(), m.count(0)), (State::Done, 10));
    // The same command again (a retried write): from its old `from` it would run away.
    write_command(&mut m, 1);
    m.advance_to(0.1);
    assert_eq!(
        (m.state(), m.count(0), command_word(&m)),
        (State::Done, 10, 0)
    );
    assert_eq!(
        outcomes(&m),
        [(4, StartOutcome::Started), (4, StartOutcome::Dropped)]
    );
    assert!(m.anomalies().is_empty());
}

#[test]
fn a_waiting_start_shows_in_the_status_block_and_a_stop_drops_it() {
    let mut m = mock(FrequencyModel::Ideal);
    start(&mut m, 0, 1, &[(0, vec![up(&[(1_000, 30)])])]);
    m.advance_to(0.005);
    start_from(
        &mut m,
        1,
        2,
        [30, 0, 0, 0],
        &[(0, vec![up(&[(1_000, 40)])])],
    );
    m.advance_to(0.009);
    assert_eq!((m.status().seq, m.status().waiting), (1, 2));
    write_command(&mut m, 2);
    m.advance_to(0.1);
    let s = m.status();
    assert_eq!((s.state, s.waiting, s.seq), (State::Stopped.word(), 0, 1));
    assert!(m.count(0) < 30);
    assert_eq!(outcomes(&m), [(1, StartOutcome::Started)], "2 never ran");
}

#[test]
fn a_waiting_start_behind_a_move_that_faults_is_dropped() {
    let mut m = mock(FrequencyModel::Ideal);
    let bad_second = up(&[(0, 20)]);
    let mut second = bad_second.clone();
    second.rows[0].freq_hz = 200_000; // out of range: F174 refuses segment 2
    start(&mut m, 0, 1, &[(0, vec![up(&[(1_000, 10)]), second])]);
    m.advance_to(0.004);
    start_from(
        &mut m,
        1,
        2,
        [10, 0, 0, 0],
        &[(0, vec![up(&[(1_000, 40)])])],
    );
    m.advance_to(0.1);
    let s = m.status();
    assert_eq!((s.state, s.fault, s.waiting), (State::Fault.word(), 4, 0));
    assert_eq!(command_word(&m), 0);
    assert_eq!(outcomes(&m), [(1, StartOutcome::Started)]);
}

#[test]
fn host_word_is_echoed_and_cleared_by_a_power_cycle_with_the_counts_and_homed_bit() {
    let mut m = mock(FrequencyModel::Ideal);
    let host = u32::from(m.config().layout.command_base + crate::contract::COMMAND_HOST_OFFSET);
    m.write_words(host, &[0xBEEF]).unwrap();
    start(&mut m, 0, 3, &[(0, vec![up(&[(1_000, 100)])])]);
    m.advance_to(0.02);
    let s = m.status();
    assert_eq!((s.host, s.ready & 1, s.seq), (0xBEEF, 1, 3));
    m.set_faults("restart@t=0.03".parse().unwrap());
    m.advance_to(0.05);
    let s = m.status();
    assert_eq!(
        (s.host, s.ready & 1, s.seq, s.state, s.busy),
        (0, 0, 0, State::Idle.word(), 0)
    );
    assert_eq!(s.elapsed, [0; 4]);
    assert_eq!(m.read_words(host, 1).unwrap(), [0]);
}

/// A power cut loses what a real FP-X loses at power-up: the counts, every Y output and the
/// non-hold relays; the hold relays (WR248..) and DT memory stay. What it lost is recorded, with
/// the counts the robot stood at.
#[test]
fn a_power_cut_turns_off_the_outputs_and_the_non_hold_relays_and_records_what_was_lost() {
    use crate::gateway::Area;
    let mut m = mock(FrequencyModel::Ideal);
    m.set_count(1, 1_234);
    m.host_write_bit(Area::R, 100, true).unwrap();
    m.host_write_bit(Area::Y, 1, true).unwrap();
    let hold = u32::from(RELAY_HOLD_WORD) * 16 + 3;
    m.host_write_bit(Area::R, hold, true).unwrap();
    m.write_words(100, &[7]).unwrap();
    assert_eq!(m.host_writes()[0].counts, [0, 1_234, 0, 0]);
    m.power_cycle();
    assert!(!m.read_bit(Area::R, 100).unwrap());
    assert!(!m.read_bit(Area::Y, 1).unwrap());
    assert!(m.read_bit(Area::R, hold).unwrap());
    assert_eq!(m.read_words(100, 1).unwrap(), [7]);
    let cut = &m.power_cuts()[0];
    assert_eq!(
        (cut.counts, cut.outputs.clone(), cut.relays.clone()),
        ([0, 1_234, 0, 0], vec![1], vec![100])
    );
    assert_eq!(m.count(1), 0);
}

#[test]
fn a_start_while_not_homed_is_refused_with_fault_six() {
    let mut m = MockPlc::new(MockConfig {
        homed: false,
        ..MockConfig::default()
    })
    .unwrap();
    assert_eq!(m.status().ready, 0b110);
    start(&mut m, 0, 1, &[(0, vec![up(&[(1_000, 5)])])]);
    m.advance_to(0.02);
    assert_eq!(
        (m.state(), m.status().fault, m.count(0)),
        (State::Fault, Fault::NotHomed.word(), 0)
    );
}

#[test]
fn home_presets_the_masked_counts_to_from_and_sets_the_homed_bit() {
    let mut m = MockPlc::new(MockConfig {
        homed: false,
        home_s: 0.05,
        ..MockConfig::default()
    })
    .unwrap();
    m.set_count(0, 1_234);
    m.set_count(3, 99);
    let block = CommandBlock {
        command: 4,
        mask: 0b0011,
        from: [10, -20, 30, 40],
        ..CommandBlock::default()
    };
    write_block(&mut m, block);
    m.advance_to(0.01);
    assert_eq!((m.state(), m.homed()), (State::Homing, false));
    m.advance_to(0.1);
    assert_eq!((m.state(), m.homed()), (State::Done, true));
    assert_eq!(
        [m.count(0), m.count(1), m.count(2), m.count(3)],
        [10, -20, 0, 99],
        "only the masked channels"
    );
    assert_eq!(m.status().ready, 0b111);
    // Now a start from those counts runs.
    start(&mut m, 1, 1, &[(0, vec![up(&[(1_000, 15)])])]);
    m.advance_to(0.2);
    assert_eq!((m.state(), m.count(0)), (State::Done, 15));
}

#[test]
fn the_estop_input_during_homing_fails_it_with_fault_seven() {
    let mut m = MockPlc::new(MockConfig {
        homed: false,
        ..MockConfig::default()
    })
    .unwrap();
    write_block(
        &mut m,
        CommandBlock {
            command: 4,
            mask: 1,
            ..CommandBlock::default()
        },
    );
    m.advance_to(0.01);
    m.set_estop_open(true);
    m.advance_to(0.02);
    assert_eq!(
        (m.state(), m.status().fault, m.homed()),
        (State::Fault, Fault::HomingFailed.word(), false)
    );
}

#[test]
fn a_start_while_the_estop_input_is_open_starts_nothing_and_latches_no_seq() {
    let mut m = mock(FrequencyModel::Ideal);
    m.set_estop_open(true);
    start(&mut m, 0, 5, &[(0, vec![up(&[(1_000, 5)])])]);
    m.advance_to(0.02);
    let s = m.status();
    assert_eq!(
        (s.state, s.fault, s.seq),
        (State::Stopped.word(), Fault::StoppedFromOutside.word(), 0)
    );
    assert!(m.take_pulses().is_empty());
    assert_eq!(
        outcomes(&m),
        [(5, StartOutcome::Refused(Fault::StoppedFromOutside))]
    );
}

fn variant_mock(variant: MockVariant) -> MockPlc {
    let mut m = MockPlc::new(MockConfig {
        model: FrequencyModel::Ideal,
        variant,
        ..MockConfig::default()
    })
    .unwrap();
    m.record_pulses(true);
    m
}

#[test]
fn busy_never_rises_keeps_the_busy_word_zero_but_still_chains_by_the_count() {
    let mut m = variant_mock(MockVariant::BusyNeverRises);
    let down = seg(Direction::Down, FrequencyRange::High, &[(1_000, 1)]);
    start(&mut m, 0, 1, &[(0, vec![up(&[(1_000, 3)]), down])]);
    let mut busy_seen = 0;
    for k in 1..50 {
        m.advance_to(f64::from(k) * SCAN);
        busy_seen |= m.status().busy;
    }
    assert_eq!(busy_seen, 0);
    assert!(m.busy(0) || m.count(0) == 1, "the engine itself did run");
    assert_eq!(
        (m.count(0), m.status().segment[0], m.state()),
        (1, 2, State::Done)
    );
}

#[test]
fn stop_pauses_halts_the_table_and_the_next_start_resumes_it() {
    let mut m = variant_mock(MockVariant::StopPauses);
    start(&mut m, 0, 1, &[(0, vec![up(&[(1_000, 100)])])]);
    m.advance_to(0.021);
    write_command(&mut m, 2);
    m.advance_to(0.030);
    let held = m.count(0);
    assert!((18..=21).contains(&held), "{held}");
    let s = m.status();
    assert_eq!((s.state, s.busy), (State::Stopped.word(), 0));
    m.advance_to(0.1);
    assert_eq!(m.count(0), held, "paused: nothing goes out");
    // The next start plays back down to 0, but the paused table resumes instead.
    let down = seg(Direction::Down, FrequencyRange::High, &[(1_000, 0)]);
    start(&mut m, 1, 2, &[(0, vec![down])]);
    m.advance_to(0.5);
    assert_eq!(m.count(0), 100);
    assert_eq!((m.state(), m.status().seq), (State::Done, 2));
}

/// Like [`start`], with a permit: the block's permit words written as a host writes them (after
/// the `host` word), then the command.
fn start_permitted(
    m: &mut MockPlc,
    seq: u16,
    permit: crate::contract::Permit,
    rows: &[(u32, i64)],
) {
    let base = u32::from(m.config().layout.command_base);
    let words = CommandBlock {
        permit,
        ..CommandBlock::default()
    }
    .to_words();
    let at = usize::from(crate::contract::COMMAND_PERMIT_OFFSET);
    m.write_words(base + at as u32, &words[at..]).unwrap();
    start(m, 0, seq, &[(0, vec![up(rows)])]);
}

/// X5 on and X6 off (press open, press not moving).
fn press_open_permit() -> crate::contract::Permit {
    use crate::contract::{Permit, PermitBit};
    Permit::of(&[
        PermitBit {
            word: 0,
            bit: 5,
            on: true,
        },
        PermitBit {
            word: 0,
            bit: 6,
            on: false,
        },
    ])
    .unwrap()
}

#[test]
fn the_status_block_copies_the_configured_input_words_every_scan() {
    let mut m = mock(FrequencyModel::Ideal);
    m.set_input(5, true).unwrap();
    m.set_input(16 + 2, true).unwrap();
    m.write_bit(crate::gateway::Area::R, 10 * 16 + 10, true)
        .unwrap();
    m.advance_to(SCAN);
    assert_eq!(m.status().inputs, [1 << 5, 1 << 2, 1 << 10, 0]);
    m.set_input(5, false).unwrap();
    m.advance_to(2.0 * SCAN);
    assert_eq!(m.status().inputs, [0, 1 << 2, 1 << 10, 0]);
}

#[test]
fn a_start_whose_permit_does_not_hold_is_refused_with_fault_8_and_nothing_moves() {
    let mut m = mock(FrequencyModel::Ideal);
    m.set_input(5, true).unwrap();
    m.set_input(6, true).unwrap(); // the press moves
    start_permitted(&mut m, 1, press_open_permit(), &[(1_000, 20)]);
    m.advance_to(0.1);
    let s = m.status();
    assert_eq!(
        (s.state, s.fault),
        (State::Fault.word(), Fault::PermitNotMet.word())
    );
    assert_eq!((s.seq, m.count(0)), (0, 0));
    assert!(m.take_pulses().is_empty());
    let record = m.starts()[0];
    assert_eq!(record.outcome, StartOutcome::Refused(Fault::PermitNotMet));
    assert_eq!(record.inputs[0], 0x60);
    // The press stops; the fault cleared, the same tables start.
    m.set_input(6, false).unwrap();
    write_command(&mut m, crate::contract::Command::ClearFault.word());
    m.advance_to(0.2);
    start_permitted(&mut m, 2, press_open_permit(), &[(1_000, 20)]);
    m.advance_to(0.3);
    assert_eq!(m.status().state, State::Done.word());
    assert_eq!(m.count(0), 20);
}

#[test]
fn a_permit_that_drops_stops_every_channel_within_one_scan_and_drops_the_waiting_start() {
    let mut m = mock(FrequencyModel::Ideal);
    m.set_input(5, true).unwrap();
    // 1 kHz for 1000 pulses: 1 s.
    start_permitted(&mut m, 1, press_open_permit(), &[(1_000, 1_000)]);
    m.advance_to(0.3);
    // A start waits behind it.
    start_permitted(&mut m, 2, crate::contract::Permit::NONE, &[(1_000, 2_000)]);
    m.advance_to(0.4);
    assert_eq!(m.status().waiting, 2);
    let dropped_at = 0.4 + SCAN / 3.0;
    m.advance_to(dropped_at);
    m.set_input(5, false).unwrap();
    m.advance_to(0.6);
    let s = m.status();
    assert_eq!(
        (s.state, s.fault),
        (State::Stopped.word(), Fault::PermitDropped.word())
    );
    assert_eq!((s.seq, s.waiting, command_word(&m)), (1, 0, 0));
    // The first scan at or after the drop stops the channel: no pulse after it.
    let first_scan = (dropped_at / SCAN).ceil() * SCAN;
    let last = times(&m.take_pulses(), 0).last().copied().unwrap();
    assert!(
        last <= first_scan + 1e-9,
        "last pulse at {last} s, scan at {first_scan} s"
    );
    assert!(m.count(0) < 1_000 && m.count(0) > 300);
    // The waiting start never ran.
    assert!(m.starts().iter().all(|r| r.block.seq != 2));
}

#[test]
fn a_cell_drives_the_inputs_every_scan_from_the_outputs_and_the_status_block_copies_them() {
    let text = include_str!("../../config/examples/cells/press.toml");
    let description = cell::Description::from_toml(text).unwrap();
    let mut m = mock(FrequencyModel::Ideal);
    m.set_cell(cell::Cell::new(description));
    m.advance_to(SCAN);
    // X2 part present, X5 open: both in WX0, the first input word.
    assert_eq!(m.status().inputs[0], (1 << 2) | (1 << 5));
    m.write_bit(crate::gateway::Area::Y, 0, true).unwrap();
    m.advance_to(3.0 * SCAN);
    assert_eq!(
        m.status().inputs[0],
        (1 << 2) | (1 << 6),
        "stroking: closed, moving"
    );
    m.advance_to(0.9);
    assert_eq!(m.status().inputs[0], 1 << 2, "settling: closed, still");
    m.advance_to(1.1);
    assert_eq!(m.status().inputs[0], (1 << 2) | (1 << 5), "open again");
    m.cell_mut().force("part_present", false).unwrap();
    m.advance_to(1.2);
    assert_eq!(m.status().inputs[0], 1 << 5, "forced off");
}
