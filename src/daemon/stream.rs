//! The live stream: one publisher task per robot builds the robot's [`Live`] snapshot in one
//! function ([`snapshot`]) each time it wakes, in one place ([`publish`]: on every change of the
//! snapshot the worker publishes, `RobotHandle::watch_snapshot`, a status read or an incident,
//! and on every change of the console's own side),
//! and pushes what changed, once, to every subscriber: the `WebSocket`s of the console, the API's
//! NDJSON streams (`status --watch`, `cycle run --follow`), the console's control tasks. N
//! subscribers cost no PLC exchange and one snapshot: nobody reads the robot per subscriber.
//!
//! ```text
//!  worker --snapshot---> watch_snapshot -+
//!  control task --seat, jog--> side -----+--> publish: snapshot() -> diff -> Frame (seq, text)
//!                                             |-> latest (watch): the whole snapshot, for a new
//!                                             |   subscriber and the control tasks
//!                                             '-> patches (broadcast, CAPACITY): every message
//! ```
//! A subscriber that falls [`CAPACITY`] messages behind is dropped (its stream ends; it
//! reconnects and starts from a whole snapshot): a slow reader never holds the publisher, and
//! the publisher never holds the worker.

use std::collections::BTreeMap;
use std::sync::Arc;

use tokio::sync::{broadcast, watch};
use tokio_util::sync::CancellationToken;

use crate::config::CellSettings;
use crate::console::patch;
use crate::contract::{INPUT_WORDS, InputArea, InputWord};
use crate::daemon::RobotHandle;
use crate::gateway::Area;
use crate::wire::{ConsoleLive, Live, LiveMessage, MoveId, MoveReport, SignalValue};

/// Messages a subscriber may fall behind before it is dropped.
pub const CAPACITY: usize = 256;

/// One published message: its number, its text (one JSON line), and the snapshot after it.
#[derive(Debug)]
pub struct Frame {
    /// The robot's message number.
    pub seq: u64,
    /// The message as sent (`{"type":"full"|"patch",...}`), no line break.
    pub text: String,
    /// The snapshot after it.
    pub live: Live,
    /// The snapshot as JSON.
    pub value: serde_json::Value,
}

/// A robot's stream.
#[derive(Debug, Clone)]
pub struct RobotStream {
    name: String,
    latest: watch::Receiver<Arc<Frame>>,
    patches: broadcast::Sender<Arc<Frame>>,
    side: Arc<watch::Sender<ConsoleLive>>,
}

/// What a new subscriber gets: the whole snapshot now, then every later message.
#[derive(Debug)]
pub struct Subscription {
    /// The whole snapshot as a `full` message.
    pub first: String,
    /// Its number: messages up to it are in it.
    pub seq: u64,
    /// Every message after it (and perhaps a few before: skip those up to `seq`).
    pub rest: broadcast::Receiver<Arc<Frame>>,
}

impl RobotStream {
    /// The robot's name.
    #[must_use]
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Subscribes: the whole snapshot, then every message after it.
    #[must_use]
    pub fn subscribe(&self) -> Subscription {
        // Subscribed before the snapshot is read: nothing between them is lost.
        let rest = self.patches.subscribe();
        let frame = Arc::clone(&self.latest.borrow());
        let first = serde_json::to_string(&LiveMessage::Full {
            robot: self.name.clone(),
            seq: frame.seq,
            live: Box::new(frame.live.clone()),
        })
        .unwrap_or_default();
        Subscription {
            first,
            seq: frame.seq,
            rest,
        }
    }

    /// The latest snapshot, woken on each new one (the control tasks read it).
    #[must_use]
    pub fn latest(&self) -> watch::Receiver<Arc<Frame>> {
        self.latest.clone()
    }

    /// The console's side of the snapshot, which the robot's control task writes.
    #[must_use]
    pub fn side(&self) -> Arc<watch::Sender<ConsoleLive>> {
        Arc::clone(&self.side)
    }

    /// How many subscribers the stream has now.
    #[must_use]
    pub fn subscribers(&self) -> usize {
        self.patches.receiver_count()
    }
}

/// The streams of every robot, their publishers running until `closing`.
#[derive(Debug, Clone, Default)]
pub struct LiveHub {
    robots: BTreeMap<String, RobotStream>,
}

/// What the snapshot needs beyond the handle: the cell's signals and the input words the PLC
/// copies (from the config).
#[derive(Debug, Clone, Default)]
pub struct SnapshotSetup {
    /// The cell's signals by name.
    pub cell: CellSettings,
    /// The four input words of the status block.
    pub inputs: Option<[InputWord; INPUT_WORDS]>,
}

impl LiveHub {
    /// Starts a publisher per robot (`setups` by robot name; none: no signals).
    #[must_use]
    pub fn start(
        robots: &BTreeMap<String, RobotHandle>,
        setups: &BTreeMap<String, SnapshotSetup>,
        closing: &CancellationToken,
    ) -> Self {
        Self::with_capacity(robots, setups, closing, CAPACITY)
    }

    /// [`Self::start`], a subscriber dropped `capacity` messages behind.
    #[must_use]
    pub fn with_capacity(
        robots: &BTreeMap<String, RobotHandle>,
        setups: &BTreeMap<String, SnapshotSetup>,
        closing: &CancellationToken,
        capacity: usize,
    ) -> Self {
        let mut streams = BTreeMap::new();
        for (name, handle) in robots {
            let setup = setups.get(name).cloned().unwrap_or_default();
            let mut tracker = Tracker::default();
            let side = Arc::new(watch::Sender::new(ConsoleLive::default()));
            let live = snapshot(handle, &setup, &ConsoleLive::default(), &mut tracker);
            let value = serde_json::to_value(&live).unwrap_or_default();
            let first = Arc::new(Frame {
                seq: 1,
                text: String::new(),
                live,
                value,
            });
            let (latest_tx, latest) = watch::channel(first);
            let (patches, _) = broadcast::channel(capacity.max(1));
            let stream = RobotStream {
                name: name.clone(),
                latest,
                patches: patches.clone(),
                side: Arc::clone(&side),
            };
            tokio::spawn(publish(
                handle.clone(),
                setup,
                tracker,
                Publisher {
                    latest: latest_tx,
                    patches,
                    side: side.subscribe(),
                },
                closing.clone(),
            ));
            streams.insert(name.clone(), stream);
        }
        Self { robots: streams }
    }

    /// A robot's stream.
    #[must_use]
    pub fn robot(&self, name: &str) -> Option<&RobotStream> {
        self.robots.get(name)
    }

    /// Every robot's stream, by name.
    #[must_use]
    pub fn robots(&self) -> &BTreeMap<String, RobotStream> {
        &self.robots
    }
}

/// The publisher's outputs and its second input.
struct Publisher {
    latest: watch::Sender<Arc<Frame>>,
    patches: broadcast::Sender<Arc<Frame>>,
    side: watch::Receiver<ConsoleLive>,
}

/// The one place the live stream wakes: each status read, each change of the console's side.
async fn publish(
    handle: RobotHandle,
    setup: SnapshotSetup,
    mut tracker: Tracker,
    mut out: Publisher,
    closing: CancellationToken,
) {
    let mut reads = handle.watch_snapshot();
    loop {
        tokio::select! {
            biased;
            () = closing.cancelled() => return,
            changed = reads.changed() => if changed.is_err() { return },
            changed = out.side.changed() => if changed.is_err() { return },
        }
        let side = out.side.borrow_and_update().clone();
        let live = snapshot(&handle, &setup, &side, &mut tracker);
        let value = serde_json::to_value(&live).unwrap_or_default();
        let before = Arc::clone(&out.latest.borrow());
        let Some(change) = patch::diff(&before.value, &value) else {
            continue;
        };
        let seq = before.seq + 1;
        let text = serde_json::to_string(&LiveMessage::Patch {
            robot: handle.robot().name.clone(),
            seq,
            patch: change,
        })
        .unwrap_or_default();
        let frame = Arc::new(Frame {
            seq,
            text,
            live,
            value,
        });
        out.latest.send_replace(Arc::clone(&frame));
        // No subscriber is no error: the snapshot is kept for the next one.
        let _ = out.patches.send(frame);
    }
}

/// What the snapshot keeps from one wake to the next: the pose and when it was read (for the
/// speed), the move seen running (for the last one that ended).
#[derive(Debug, Default)]
pub struct Tracker {
    pose_at: Option<([f64; 4], u64, tokio::time::Instant)>,
    speed_mm_s: Option<f64>,
    running: Option<MoveId>,
    last: Option<MoveId>,
}

/// The robot's live snapshot: the one function that reads the robot for the console and the
/// stream (through `RobotHandle`'s public methods only).
#[must_use]
pub fn snapshot(
    handle: &RobotHandle,
    setup: &SnapshotSetup,
    side: &ConsoleLive,
    tracker: &mut Tracker,
) -> Live {
    let state = handle.state();
    let reads = handle.snapshot().reads;
    let robot = handle.robot();
    let joints = state.counts.map(|counts| {
        robot
            .joints
            .iter()
            .map(|j| j.user(j.value_of(counts[usize::from(j.channel)])))
            .collect()
    });
    let speed_mm_s = tracker.speed(state.pose, reads);
    if state.current_move != tracker.running {
        if let Some(ended) = tracker.running {
            tracker.last = Some(ended);
        }
        tracker.running = state.current_move;
    }
    let current = state.current_move.and_then(|id| handle.report(id));
    let path = current.as_ref().and_then(|r| {
        let position = |counts: [i64; 4]| {
            let by_joint = std::array::from_fn(|j| counts[usize::from(robot.joints[j].channel)]);
            let p = robot.pose_of(&by_joint).position_mm;
            [p.x, p.y, p.z]
        };
        Some([position(r.start_counts?), position(r.target_counts?)])
    });
    let last: Option<MoveReport> = tracker.last.and_then(|id| handle.report(id));
    Live {
        signals: signals(&setup.cell, setup.inputs.as_ref(), state.inputs.as_ref()),
        reads,
        joints,
        speed_mm_s,
        current,
        path,
        last,
        speed_override_pct: handle.speed_override(),
        console: side.clone(),
        state,
    }
}

impl Tracker {
    /// The tool's speed over the last status read that moved the counts, mm/s (0 when a read
    /// shows them still).
    fn speed(&mut self, pose: Option<[f64; 4]>, reads: u64) -> Option<f64> {
        let now = tokio::time::Instant::now();
        let Some(pose) = pose else {
            self.pose_at = None;
            self.speed_mm_s = None;
            return None;
        };
        match self.pose_at {
            Some((before, seen, at)) if seen != reads => {
                let dt = now.duration_since(at).as_secs_f64();
                let d = ((pose[0] - before[0]).powi(2)
                    + (pose[1] - before[1]).powi(2)
                    + (pose[2] - before[2]).powi(2))
                .sqrt();
                if dt > 1e-3 {
                    self.speed_mm_s = Some(d / dt);
                }
                self.pose_at = Some((pose, reads, now));
            }
            Some(_) => {}
            None => {
                self.pose_at = Some((pose, reads, now));
                self.speed_mm_s = Some(0.0);
            }
        }
        self.speed_mm_s
    }
}

/// The cell's signals with their values where the status block's input words carry them.
fn signals(
    cell: &CellSettings,
    words: Option<&[InputWord; INPUT_WORDS]>,
    inputs: Option<&[u16; INPUT_WORDS]>,
) -> Vec<SignalValue> {
    cell.signals
        .iter()
        .map(|(name, address)| {
            let (word, bit) = (address.index / 16, address.index % 16);
            let area = match address.area {
                Area::X => Some(InputArea::X),
                Area::R => Some(InputArea::R),
                Area::Y | Area::Dt => None,
            };
            let slot = words.and_then(|w| {
                w.iter()
                    .position(|iw| Some(iw.area) == area && u32::from(iw.word) == word)
            });
            let value = slot
                .zip(inputs)
                .map(|(slot, inputs)| inputs[slot] & (1 << bit) != 0);
            SignalValue {
                name: name.clone(),
                address: address.to_string(),
                value,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_signal_in_an_input_word_reads_its_bit_and_others_read_none() {
        let mut cell = CellSettings::default();
        cell.signals
            .insert("press_open".into(), "X5".parse().unwrap());
        cell.signals.insert("clamp".into(), "R10A".parse().unwrap());
        cell.signals
            .insert("press_go".into(), "Y0".parse().unwrap());
        let words = InputWord::DEFAULTS;
        let inputs = [1 << 5, 0, 1 << 0xA, 0];
        let got = signals(&cell, Some(&words), Some(&inputs));
        let value = |n: &str| got.iter().find(|s| s.name == n).unwrap().value;
        assert_eq!(value("press_open"), Some(true));
        assert_eq!(value("clamp"), Some(true));
        assert_eq!(value("press_go"), None);
        let down = signals(&cell, Some(&words), None);
        assert!(down.iter().all(|s| s.value.is_none()));
    }
}
