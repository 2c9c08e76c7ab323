//! The daemon's metrics as lifetime state (`prometheus-client`): counters and histograms kept from
//! the daemon's start, fed where things happen (a move ends, the link reopens, a gateway request
//! is answered), never recomputed from the kept reports, so a counter never goes down. Gauges
//! that only restate a robot's state are set from it when `/metrics` is read
//! ([`crate::daemon::api::metrics`]).
//!
//! One [`Metrics`] per daemon, shared by every robot (a label per robot); docs/API.md lists every
//! metric.

use std::collections::BTreeMap;
use std::sync::atomic::AtomicU64;
use std::sync::{Arc, Mutex, PoisonError};

use prometheus_client::collector::Collector;
use prometheus_client::encoding::{DescriptorEncoder, EncodeLabelSet, EncodeMetric, MetricEncoder};
use prometheus_client::metrics::MetricType;
use prometheus_client::metrics::counter::{ConstCounter, Counter};
use prometheus_client::metrics::family::Family;
use prometheus_client::metrics::gauge::{ConstGauge, Gauge};
use prometheus_client::metrics::histogram::Histogram;
use prometheus_client::metrics::info::Info;
use prometheus_client::registry::Registry;

use crate::plc::ExchangeCounts;
use crate::wire::PalletStatus;
use crate::wire::Stage;

/// The label every per-robot series carries.
#[derive(Debug, Clone, PartialEq, Eq, Hash, EncodeLabelSet)]
pub struct RobotLabel {
    /// The robot's name in the config.
    pub robot: String,
}

/// A move's end, by outcome.
#[derive(Debug, Clone, PartialEq, Eq, Hash, EncodeLabelSet)]
struct OutcomeLabels {
    robot: String,
    outcome: &'static str,
}

type Histograms = Family<RobotLabel, Histogram, fn() -> Histogram>;

/// Upload time buckets, s: a small move over a fast link takes tens of ms, a long table over
/// 9600 baud several seconds.
fn upload_histogram() -> Histogram {
    Histogram::new([0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 5.0, 10.0])
}

/// Motion time buckets, s.
fn motion_histogram() -> Histogram {
    Histogram::new([0.25, 0.5, 1.0, 2.5, 5.0, 10.0, 30.0, 60.0])
}

/// How long a cycle took, s.
fn cycle_histogram() -> Histogram {
    Histogram::new([1.0, 2.5, 5.0, 10.0, 20.0, 30.0, 60.0, 120.0])
}

/// How long a cycle's wait step waited, s.
fn cycle_wait_histogram() -> Histogram {
    Histogram::new([0.01, 0.05, 0.1, 0.5, 1.0, 5.0, 30.0, 120.0])
}

/// A cycle's wait step: the robot, the program and the step.
#[derive(Debug, Clone, Hash, PartialEq, Eq, EncodeLabelSet)]
struct WaitLabels {
    robot: String,
    program: String,
    step: String,
}

/// A cell face command: the robot, and the command (`start`, `strobe`, ...) or the refusal's
/// code.
#[derive(Debug, Clone, Hash, PartialEq, Eq, EncodeLabelSet)]
struct FaceLabels {
    robot: String,
    what: String,
}

/// How long a due status read waited behind one gateway exchange, s.
fn wait_histogram() -> Histogram {
    Histogram::new([0.001, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5])
}

/// The daemon's metrics: a registry and the families in it. Clones share them.
#[derive(Debug, Clone)]
pub struct Metrics {
    inner: Arc<Inner>,
}

#[derive(Debug)]
struct Inner {
    registry: Registry,
    moves: Family<OutcomeLabels, Counter>,
    reconnects: Family<RobotLabel, Counter>,
    gateway_requests: Family<RobotLabel, Counter>,
    gateway_errors: Family<RobotLabel, Counter>,
    upload: Histograms,
    motion: Histograms,
    gateway_wait: Histograms,
    cycles: Family<RobotLabel, Counter>,
    cycle_time: Histograms,
    cycle_wait: Family<WaitLabels, Histogram, fn() -> Histogram>,
    face_commands: Family<FaceLabels, Counter>,
    face_refusals: Family<FaceLabels, Counter>,
    /// Set from the robots' state at every read of `/metrics`.
    link_up: Family<RobotLabel, Gauge>,
    fault: Family<RobotLabel, Gauge>,
    heartbeat_age: Family<RobotLabel, Gauge<f64, AtomicU64>>,
    exchanges: Arc<ExchangeCollector>,
    pallets: Arc<PalletCollector>,
}

/// A counter family read from [`ExchangeCounts`]: name, help, value.
type ExchangeFamily = (&'static str, &'static str, fn(&ExchangeCounts) -> u64);

/// Every robot's link exchange counts, read at each scrape.
#[derive(Debug, Default)]
struct ExchangeCollector {
    links: Mutex<Vec<(RobotLabel, Arc<ExchangeCounts>)>>,
}

impl Collector for ExchangeCollector {
    fn encode(&self, mut encoder: DescriptorEncoder<'_>) -> Result<(), std::fmt::Error> {
        let links = self.links.lock().unwrap_or_else(PoisonError::into_inner);
        let families: [ExchangeFamily; 2] = [
            (
                "linterpd_link_exchange_retries",
                "Exchanges with the PLC tried again (after a timeout or a garbled reply).",
                ExchangeCounts::retries,
            ),
            (
                "linterpd_link_exchange_timeouts",
                "Exchange attempts that got no complete reply in time.",
                ExchangeCounts::timeouts,
            ),
        ];
        for (name, help, value) in families {
            let kind = ConstCounter::new(0_u64).metric_type();
            let mut family = encoder.encode_descriptor(name, help, None, kind)?;
            for (label, counts) in links.iter() {
                ConstCounter::new(value(counts)).encode(family.encode_family(label)?)?;
            }
        }
        Ok(())
    }
}

/// A pallet's series: the robot and the pallet.
#[derive(Debug, Clone, PartialEq, Eq, Hash, EncodeLabelSet)]
struct PalletLabels {
    robot: String,
    pallet: String,
}

/// A pallet's counts for its series: parts, pallets done, the slot to fill next.
type PalletCounts = (u64, u64, usize);

/// A counter family read from [`PalletCounts`]: name, help, value.
type PalletFamily = (&'static str, &'static str, fn(&PalletCounts) -> u64);

/// Every pallet's counts as its counter last gave them (parts, pallets done, the next slot),
/// read at each scrape: the counters live in the state directory and survive a restart, so
/// these never go down.
#[derive(Debug, Default)]
struct PalletCollector {
    counts: Mutex<BTreeMap<(String, String), PalletCounts>>,
}

impl Collector for PalletCollector {
    fn encode(&self, mut encoder: DescriptorEncoder<'_>) -> Result<(), std::fmt::Error> {
        let counts = self.counts.lock().unwrap_or_else(PoisonError::into_inner);
        let labels = |(robot, pallet): &(String, String)| PalletLabels {
            robot: robot.clone(),
            pallet: pallet.clone(),
        };
        let counters: [PalletFamily; 2] = [
            (
                "linterpd_pallet_parts",
                "Parts placed on (or picked from) each pallet, from its counter.",
                |c| c.0,
            ),
            (
                "linterpd_pallets",
                "Pallets completed (filled, then begun again at slot 0), from each pallet's counter.",
                |c| c.1,
            ),
        ];
        for (name, help, value) in counters {
            let kind = ConstCounter::new(0_u64).metric_type();
            let mut family = encoder.encode_descriptor(name, help, None, kind)?;
            for (key, c) in counts.iter() {
                ConstCounter::new(value(c)).encode(family.encode_family(&labels(key))?)?;
            }
        }
        let kind = ConstGauge::new(0_i64).metric_type();
        let mut family = encoder.encode_descriptor(
            "linterpd_pallet_index",
            "Each pallet's slot to fill next, from 0: the slots filled.",
            None,
            kind,
        )?;
        for (key, c) in counts.iter() {
            let index = i64::try_from(c.2).unwrap_or(i64::MAX);
            ConstGauge::new(index).encode(family.encode_family(&labels(key))?)?;
        }
        Ok(())
    }
}

impl Default for Metrics {
    fn default() -> Self {
        Self::new()
    }
}

impl Metrics {
    /// Empty metrics, with `linterpd_build_info`.
    #[must_use]
    pub fn new() -> Self {
        let mut registry = Registry::default();
        // (`register` adds the help text's period.)
        let build = Info::new(vec![
            ("version", env!("CARGO_PKG_VERSION")),
            ("commit", env!("LINTERPD_COMMIT")),
        ]);
        registry.register(
            "linterpd_build",
            "The running linterpd's version and commit",
            build,
        );
        let inner = Inner {
            moves: Family::default(),
            reconnects: Family::default(),
            gateway_requests: Family::default(),
            gateway_errors: Family::default(),
            upload: Family::new_with_constructor(upload_histogram),
            motion: Family::new_with_constructor(motion_histogram),
            gateway_wait: Family::new_with_constructor(wait_histogram),
            cycles: Family::default(),
            cycle_time: Family::new_with_constructor(cycle_histogram),
            cycle_wait: Family::new_with_constructor(cycle_wait_histogram),
            face_commands: Family::default(),
            face_refusals: Family::default(),
            link_up: Family::default(),
            fault: Family::default(),
            heartbeat_age: Family::default(),
            exchanges: Arc::default(),
            pallets: Arc::default(),
            registry,
        };
        Self {
            inner: Arc::new(inner.registered()),
        }
    }

    /// The per-robot handle for `robot`: its series start at 0 (a counter is there before its
    /// first event).
    #[must_use]
    pub fn robot(&self, robot: &str) -> RobotMetrics {
        let label = RobotLabel {
            robot: robot.to_owned(),
        };
        let i = &self.inner;
        for outcome in Stage::FINAL.map(Stage::name) {
            drop(i.moves.get_or_create(&OutcomeLabels {
                robot: robot.to_owned(),
                outcome,
            }));
        }
        for family in [
            &i.reconnects,
            &i.gateway_requests,
            &i.gateway_errors,
            &i.cycles,
        ] {
            drop(family.get_or_create(&label));
        }
        for family in [&i.upload, &i.motion, &i.gateway_wait, &i.cycle_time] {
            drop(family.get_or_create(&label));
        }
        let exchanges = Arc::new(ExchangeCounts::default());
        i.exchanges
            .links
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .push((label.clone(), Arc::clone(&exchanges)));
        RobotMetrics {
            metrics: self.clone(),
            label,
            exchanges,
        }
    }

    /// Sets the gauges that restate a robot's state: link up, fault code, heartbeat age (no
    /// series while the age is unknown).
    pub fn set_state(&self, robot: &str, link_up: bool, fault: u16, heartbeat_age_s: Option<f64>) {
        let label = RobotLabel {
            robot: robot.to_owned(),
        };
        let i = &self.inner;
        i.link_up.get_or_create(&label).set(i64::from(link_up));
        i.fault.get_or_create(&label).set(i64::from(fault));
        match heartbeat_age_s {
            Some(age) => {
                i.heartbeat_age.get_or_create(&label).set(age);
            }
            None => {
                i.heartbeat_age.remove(&label);
            }
        }
    }

    /// Sets robot `robot`'s pallets' series from their counts now (a pallet no longer
    /// configured loses its series).
    pub fn set_pallets(&self, robot: &str, pallets: &[PalletStatus]) {
        let collector = &self.inner.pallets.counts;
        let mut counts = collector.lock().unwrap_or_else(PoisonError::into_inner);
        counts.retain(|(r, _), _| r != robot);
        for p in pallets {
            let key = (robot.to_owned(), p.name.clone());
            counts.insert(key, (p.parts, p.pallets, p.index));
        }
    }

    /// The `OpenMetrics` text of everything.
    ///
    /// # Panics
    /// Never: writing into a `String` cannot fail.
    #[must_use]
    pub fn encode(&self) -> String {
        let mut out = String::new();
        prometheus_client::encoding::text::encode(&mut out, &self.inner.registry)
            .expect("writing to a String cannot fail");
        out
    }
}

/// A family in [`FAMILIES`]: its name, its help, the family.
type RegisteredFamily = (&'static str, &'static str, fn(&Inner) -> AnyFamily);

/// Every family, in the order `/metrics` shows them (the collectors' after): its name, its
/// help (`Registry::register` ends it with a period itself: the texts here have none; a
/// collector's, written as they are, do), and the family.
const FAMILIES: [RegisteredFamily; 15] = [
    ("linterpd_moves", "Moves that ended, by outcome", |m| {
        AnyFamily::of(&m.moves)
    }),
    (
        "linterpd_link_reconnects",
        "PLC link reopened after it was lost (the first opening is not counted)",
        |m| AnyFamily::of(&m.reconnects),
    ),
    (
        "linterpd_gateway_requests",
        "Register gateway requests answered (read or write)",
        |m| AnyFamily::of(&m.gateway_requests),
    ),
    (
        "linterpd_gateway_errors",
        "Register gateway requests that failed (link down, PLC error)",
        |m| AnyFamily::of(&m.gateway_errors),
    ),
    (
        "linterpd_upload_seconds",
        "Time to write and verify a move's bank",
        |m| AnyFamily::of(&m.upload),
    ),
    (
        "linterpd_motion_seconds",
        "Time from a move's start to its end on the PLC (moves that ended done)",
        |m| AnyFamily::of(&m.motion),
    ),
    (
        "linterpd_gateway_motion_wait_seconds",
        "How long a due status read waited behind a gateway exchange",
        |m| AnyFamily::of(&m.gateway_wait),
    ),
    (
        "linterpd_cycles",
        "Cycle programs' cycles run to their end",
        |m| AnyFamily::of(&m.cycles),
    ),
    (
        "linterpd_cycle_seconds",
        "Time a cycle took, from its first step to the end of its last",
        |m| AnyFamily::of(&m.cycle_time),
    ),
    (
        "linterpd_cycle_wait_seconds",
        "Time a cycle's wait step waited, by program and step",
        |m| AnyFamily::of(&m.cycle_wait),
    ),
    (
        "linterpd_face_commands",
        "Cell face commands taken from the line (an edge of a command bit), by command",
        |m| AnyFamily::of(&m.face_commands),
    ),
    (
        "linterpd_face_refusals",
        "Cell face commands refused, by the refusal word's code",
        |m| AnyFamily::of(&m.face_refusals),
    ),
    (
        "linterpd_link_up",
        "1 while the PLC link is up and the contract answers",
        |m| AnyFamily::of(&m.link_up),
    ),
    (
        "linterpd_plc_fault",
        "The PLC program's fault code (0: none), as last read",
        |m| AnyFamily::of(&m.fault),
    ),
    (
        "linterpd_heartbeat_age_seconds",
        "Time since the PLC program's heartbeat last changed",
        |m| AnyFamily::of(&m.heartbeat_age),
    ),
];

impl Inner {
    /// Registers every family ([`FAMILIES`]), then the exchanges' and the pallets' collectors.
    fn registered(mut self) -> Self {
        for (name, help, family) in FAMILIES {
            let family = family(&self);
            self.registry.register(name, help, family);
        }
        let r = &mut self.registry;
        r.register_collector(Box::new(Arc::clone(&self.exchanges)));
        r.register_collector(Box::new(Arc::clone(&self.pallets)));
        self
    }
}

/// A family of any kind, so that every family can stand in one table ([`FAMILIES`]).
#[derive(Debug)]
struct AnyFamily(Box<dyn Encodes>);

/// What a registered family is.
trait Encodes: EncodeMetric + Send + Sync + std::fmt::Debug {}

impl<T: EncodeMetric + Send + Sync + std::fmt::Debug> Encodes for T {}

impl AnyFamily {
    fn of<F: Encodes + Clone + 'static>(family: &F) -> Self {
        Self(Box::new(family.clone()))
    }
}

impl EncodeMetric for AnyFamily {
    fn encode(&self, encoder: MetricEncoder<'_>) -> Result<(), std::fmt::Error> {
        self.0.encode(encoder)
    }

    fn metric_type(&self) -> MetricType {
        self.0.metric_type()
    }

    fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

/// One robot's side of the metrics, fed by its worker.
#[derive(Debug, Clone)]
pub struct RobotMetrics {
    metrics: Metrics,
    label: RobotLabel,
    exchanges: Arc<ExchangeCounts>,
}

impl RobotMetrics {
    /// A move reached its final stage.
    pub fn move_ended(&self, stage: Stage) {
        let labels = OutcomeLabels {
            robot: self.label.robot.clone(),
            outcome: stage.name(),
        };
        self.metrics.inner.moves.get_or_create(&labels).inc();
    }

    /// The link was opened again after it was lost.
    pub fn reconnected(&self) {
        self.metrics
            .inner
            .reconnects
            .get_or_create(&self.label)
            .inc();
    }

    /// A gateway request was answered; `failed` when with an error.
    pub fn gateway_request(&self, failed: bool) {
        let i = &self.metrics.inner;
        i.gateway_requests.get_or_create(&self.label).inc();
        if failed {
            i.gateway_errors.get_or_create(&self.label).inc();
        }
    }

    /// A move's bank took `seconds` to write and verify.
    pub fn uploaded(&self, seconds: f64) {
        self.metrics
            .inner
            .upload
            .get_or_create(&self.label)
            .observe(seconds);
    }

    /// A move ran `seconds` on the PLC.
    pub fn moved(&self, seconds: f64) {
        self.metrics
            .inner
            .motion
            .get_or_create(&self.label)
            .observe(seconds);
    }

    /// A cycle ended, after `seconds`.
    pub fn cycle_done(&self, seconds: f64) {
        let i = &self.metrics.inner;
        i.cycles.get_or_create(&self.label).inc();
        i.cycle_time.get_or_create(&self.label).observe(seconds);
    }

    /// Wait step `step` of `program` waited `seconds`.
    pub fn cycle_waited(&self, program: &str, step: usize, seconds: f64) {
        let labels = WaitLabels {
            robot: self.label.robot.clone(),
            program: program.to_owned(),
            step: step.to_string(),
        };
        self.metrics
            .inner
            .cycle_wait
            .get_or_create(&labels)
            .observe(seconds);
    }

    /// The cell face took command `what` (`start`, `strobe`, `hold`...).
    pub fn face_command(&self, what: &str) {
        let labels = FaceLabels {
            robot: self.label.robot.clone(),
            what: what.to_owned(),
        };
        self.metrics
            .inner
            .face_commands
            .get_or_create(&labels)
            .inc();
    }

    /// The cell face refused a command with refusal `code`.
    pub fn face_refused(&self, code: u16) {
        let labels = FaceLabels {
            robot: self.label.robot.clone(),
            what: code.to_string(),
        };
        self.metrics
            .inner
            .face_refusals
            .get_or_create(&labels)
            .inc();
    }

    /// A due status read waited `seconds` behind a gateway exchange.
    pub fn waited_behind_gateway(&self, seconds: f64) {
        let i = &self.metrics.inner;
        i.gateway_wait.get_or_create(&self.label).observe(seconds);
    }

    /// The counts every client of this robot's link counts into.
    #[must_use]
    pub fn exchange_counts(&self) -> Arc<ExchangeCounts> {
        Arc::clone(&self.exchanges)
    }

    /// The daemon's metrics this belongs to.
    #[must_use]
    pub fn daemon(&self) -> &Metrics {
        &self.metrics
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line<'a>(text: &'a str, start: &str) -> &'a str {
        text.lines()
            .find(|l| l.starts_with(start))
            .unwrap_or_else(|| panic!("no {start:?} in\n{text}"))
    }

    #[test]
    fn metrics_help_lines_end_in_one_period_not_two() {
        let metrics = Metrics::new();
        let _ = metrics.robot("a");
        let text = metrics.encode();
        let help: Vec<&str> = text.lines().filter(|l| l.starts_with("# HELP")).collect();
        assert!(help.len() > 10, "{text}");
        for line in help {
            assert!(line.ends_with('.') && !line.ends_with(".."), "{line}");
        }
    }

    #[test]
    fn series_start_at_zero_and_only_count_up() {
        let metrics = Metrics::new();
        let a = metrics.robot("a");
        let text = metrics.encode();
        assert_eq!(
            line(&text, "linterpd_moves_total{robot=\"a\",outcome=\"done\"}"),
            "linterpd_moves_total{robot=\"a\",outcome=\"done\"} 0"
        );
        assert!(
            text.contains("linterpd_link_reconnects_total{robot=\"a\"} 0"),
            "{text}"
        );
        assert!(
            text.contains("linterpd_upload_seconds_sum{robot=\"a\"} 0.0"),
            "{text}"
        );
        assert!(!text.contains("-0"), "{text}");
        a.move_ended(Stage::Done);
        a.move_ended(Stage::Failed);
        a.reconnected();
        a.gateway_request(true);
        a.uploaded(0.3);
        a.exchange_counts().retried();
        a.face_command("start");
        a.face_refused(7);
        let text = metrics.encode();
        for want in [
            "linterpd_moves_total{robot=\"a\",outcome=\"done\"} 1",
            "linterpd_moves_total{robot=\"a\",outcome=\"failed\"} 1",
            "linterpd_link_reconnects_total{robot=\"a\"} 1",
            "linterpd_gateway_requests_total{robot=\"a\"} 1",
            "linterpd_gateway_errors_total{robot=\"a\"} 1",
            "linterpd_upload_seconds_count{robot=\"a\"} 1",
            "linterpd_link_exchange_retries_total{robot=\"a\"} 1",
            "linterpd_link_exchange_timeouts_total{robot=\"a\"} 0",
            "linterpd_face_commands_total{robot=\"a\",what=\"start\"} 1",
            "linterpd_face_refusals_total{robot=\"a\",what=\"7\"} 1",
        ] {
            assert!(text.lines().any(|l| l == want), "no {want:?} in\n{text}");
        }
        assert!(text.ends_with("# EOF\n"));
    }

    #[test]
    fn pallet_series_come_from_the_counters_and_follow_the_configured_pallets() {
        use crate::pallet::Counter;
        let metrics = Metrics::new();
        let counter = Counter {
            index: 7,
            parts: 31,
            pallets: 1,
            ..Counter::default()
        };
        let layers = [0; 24];
        let out = PalletStatus::new("out", &counter, &layers, true);
        let inn = PalletStatus::new("in", &Counter::default(), &layers, true);
        metrics.set_pallets("a", &[out.clone(), inn]);
        metrics.set_pallets("b", &[out]);
        let text = metrics.encode();
        for want in [
            "# TYPE linterpd_pallet_parts counter",
            "linterpd_pallet_parts_total{robot=\"a\",pallet=\"out\"} 31",
            "linterpd_pallet_parts_total{robot=\"a\",pallet=\"in\"} 0",
            "linterpd_pallets_total{robot=\"a\",pallet=\"out\"} 1",
            "linterpd_pallets_total{robot=\"b\",pallet=\"out\"} 1",
            "linterpd_pallet_index{robot=\"a\",pallet=\"out\"} 7",
        ] {
            assert!(text.lines().any(|l| l == want), "no {want:?} in\n{text}");
        }
        // Robot a's pallet "in" is gone from its config: its series go, b's stay.
        let done = Counter {
            parts: 32,
            ..counter
        };
        metrics.set_pallets("a", &[PalletStatus::new("out", &done, &layers, true)]);
        let text = metrics.encode();
        assert!(!text.contains("pallet=\"in\""), "{text}");
        assert!(
            text.contains("linterpd_pallet_parts_total{robot=\"a\",pallet=\"out\"} 32"),
            "{text}"
        );
        assert!(text.contains("linterpd_pallets_total{robot=\"b\",pallet=\"out\"} 1"));
    }

    #[test]
    fn build_info_names_version_and_commit() {
        let text = Metrics::new().encode();
        let info = line(&text, "linterpd_build_info{");
        assert!(
            info.contains(&format!("version=\"{}\"", env!("CARGO_PKG_VERSION"))),
            "{info}"
        );
        assert!(info.contains("commit=\""), "{info}");
        assert!(info.ends_with(" 1"), "{info}");
    }

    #[test]
    fn state_gauges_follow_the_state_and_an_unknown_age_has_no_series() {
        let metrics = Metrics::new();
        metrics.set_state("a", true, 5, Some(0.02));
        let text = metrics.encode();
        assert!(text.contains("linterpd_plc_fault{robot=\"a\"} 5"), "{text}");
        assert!(text.contains("linterpd_link_up{robot=\"a\"} 1"), "{text}");
        assert!(
            text.contains("linterpd_heartbeat_age_seconds{robot=\"a\"} 0.02"),
            "{text}"
        );
        metrics.set_state("a", false, 0, None);
        let text = metrics.encode();
        assert!(text.contains("linterpd_link_up{robot=\"a\"} 0"), "{text}");
        assert!(!text.contains("linterpd_heartbeat_age_seconds{"), "{text}");
    }
}
