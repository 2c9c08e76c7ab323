//! PURE. The config lines to paste into `linterpd.toml`, from what the commission measured:
//! one line per setting it has a figure for, the measured value (or the configured one, when it
//! already fits) and a comment saying what it rests on. Settings it has no figure for are left
//! out.

use super::Target;
use super::judge::Fit;
use super::report::Findings;
use crate::mewtocol::{Header, max_read_reply_words, max_write_words};
use crate::plc::Protocol;
use crate::table::FrequencyModel;

/// Milliseconds rounded up to whole 10 ms, as the config writes durations.
fn ms(value_ms: f64) -> String {
    super::link::lines_ms(value_ms)
}

fn header_line(findings: &Findings) -> Option<String> {
    let answered = |name: &str| {
        findings
            .headers
            .iter()
            .any(|h| h.header == name && h.answered)
    };
    let carries = |name: &str, header: Header| {
        findings.sizes.iter().any(|s| {
            s.framing == name
                && s.read_words >= max_read_reply_words(header)
                && s.write_words >= max_write_words(header)
        })
    };
    if findings.headers.is_empty() {
        return None;
    }
    Some(if answered("<") && carries("<", Header::Angle) {
        "header = \"angle\"  # < answered and carries 509-word reads, 507-word writes".to_owned()
    } else if answered("<") {
        "header = \"percent\"  # < answered but takes less than linterpd's < frames".to_owned()
    } else if answered("%") {
        "header = \"percent\"  # < got no answer".to_owned()
    } else {
        return None;
    })
}

fn multi_frame_line(findings: &Findings) -> Option<String> {
    let line = if findings.multi_frame_reads? {
        "multi_frame_reads = true  # a % read past one frame came back in several frames"
    } else {
        "multi_frame_reads = false  # a % read past one frame got no answer"
    };
    Some(line.to_owned())
}

fn modbus_lines(findings: &Findings) -> Vec<String> {
    let Some(sizes) = findings.sizes.iter().find(|s| s.framing == "modbus") else {
        return Vec::new();
    };
    vec![
        format!(
            "modbus_max_read = {}  # the largest read the PLC took",
            sizes.read_words
        ),
        format!(
            "modbus_max_write = {}  # the largest write the PLC took",
            sizes.write_words
        ),
    ]
}

fn timing_lines(target: &Target, findings: &Findings) -> Vec<String> {
    let link = &target.link;
    let mut out = Vec::new();
    if let Some(rt) = findings.round_trip_status {
        let configured = link.timeout.as_secs_f64() * 1e3;
        let value = if rt.max_ms * 2.0 > configured {
            ms(3.0 * rt.max_ms)
        } else {
            ms(configured)
        };
        out.push(format!(
            "timeout = \"{value}\"  # a status read took at most {:.1} ms",
            rt.max_ms
        ));
    }
    if let Some(mean_s) = findings.scan.and_then(|s| s.mean_scan_s) {
        let configured = link.scan_time.as_secs_f64() * 1e3;
        let value = if mean_s * 1e3 > configured {
            format!("{}ms", (2.0 * mean_s * 1e3).ceil() as u64)
        } else {
            format!("{}ms", configured.round() as u64)
        };
        out.push(format!(
            "scan_time = \"{value}\"  # mean scan {:.2} ms (scan_time is the longest)",
            mean_s * 1e3
        ));
    }
    out
}

fn model_line(target: &Target, findings: &Findings) -> Option<String> {
    let rates = &findings.rates;
    let first = rates.first()?;
    let configured = target.robot.motion.frequency_model;
    let all = |fit: Fit| rates.iter().all(|r| r.rate.fit == fit);
    let channels: Vec<String> = rates.iter().map(|r| r.channel.to_string()).collect();
    let figures = format!(
        "{} Hz ran at {:.2} Hz on channel {}",
        first.rate.set_hz, first.rate.measured_hz, first.channel
    );
    let (model, why) = if all(Fit::FpxDivider) {
        (FrequencyModel::FpxDivider, "fits".to_owned())
    } else if all(Fit::Ideal) {
        (FrequencyModel::Ideal, "fits".to_owned())
    } else if rates.iter().all(|r| r.rate.fit.admits(configured)) {
        (
            configured,
            "kept: the measurement could not tell".to_owned(),
        )
    } else {
        (
            configured,
            format!(
                "kept, but the channels disagree ({}): see the report",
                channels.join(", ")
            ),
        )
    };
    let on = if channels.len() == 1 {
        "channel"
    } else {
        "channels"
    };
    Some(format!(
        "frequency_model = \"{}\"  # {why} on {on} {} ({figures})",
        model.name(),
        channels.join(", ")
    ))
}

/// The lines, under their table headers, for `target`'s robot.
#[must_use]
pub fn config_lines(target: &Target, findings: &Findings) -> Vec<String> {
    let name = &target.robot.name;
    let mut plc = Vec::new();
    if target.link.protocol == Protocol::Mewtocol {
        plc.extend(header_line(findings));
        plc.extend(multi_frame_line(findings));
    } else {
        plc.extend(modbus_lines(findings));
    }
    plc.extend(timing_lines(target, findings));
    let mut out = Vec::new();
    if !plc.is_empty() {
        out.push(format!("[robots.{name}.plc]"));
        out.extend(plc);
    }
    if let Some(line) = model_line(target, findings) {
        out.push(format!("[robots.{name}.motion]"));
        out.push(line);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::commission::judge::{RateFit, ScanRate, Spread};
    use crate::commission::report::{ChannelRate, HeaderProbe, RequestSizes};
    use crate::plc::{LinkSettings, TcpSettings, Transport};

    fn target(protocol: Protocol) -> Target {
        let link = LinkSettings::new(
            protocol,
            Transport::Tcp(TcpSettings {
                address: "192.168.1.5:9094".into(),
                connect_timeout: std::time::Duration::from_secs(2),
            }),
        );
        Target::new(crate::robot::seed_robot(), link)
    }

    fn rate(channel: u8, fit: Fit) -> ChannelRate {
        ChannelRate {
            channel,
            rate: RateFit {
                set_hz: 1_878,
                pulses: 500,
                samples: 80,
                measured_hz: 1_842.6,
                tolerance_hz: 2.0,
                ideal_hz: 1_878.0,
                divider_hz: 1_842.57,
                fit,
            },
        }
    }

    fn sizes(framing: &str, read: usize, write: usize) -> RequestSizes {
        RequestSizes {
            framing: framing.into(),
            read_words: read,
            read_refused: None,
            write_words: write,
            write_refused: None,
            largest_frame_chars: None,
        }
    }

    #[test]
    fn mewtocol_lines_name_the_header_timing_and_model() {
        let findings = Findings {
            headers: vec![
                HeaderProbe {
                    header: "%".into(),
                    answered: true,
                    outcome: String::new(),
                },
                HeaderProbe {
                    header: "<".into(),
                    answered: true,
                    outcome: String::new(),
                },
            ],
            sizes: vec![sizes("%", 27, 24), sizes("<", 64, 64)],
            round_trip_status: Some(Spread {
                count: 10,
                min_ms: 100.0,
                median_ms: 150.0,
                max_ms: 180.0,
            }),
            scan: Some(ScanRate {
                scans: 100,
                window_s: 1.2,
                mean_scan_s: Some(0.012),
                longest_still_s: 0.02,
            }),
            rates: vec![rate(0, Fit::FpxDivider), rate(1, Fit::FpxDivider)],
            ..Findings::default()
        };
        let lines = config_lines(&target(Protocol::Mewtocol), &findings);
        assert_eq!(lines[0], "[robots.press-loader.plc]");
        assert!(lines[1].starts_with("header = \"percent\"  # < answered but takes less"));
        assert!(lines[2].starts_with("timeout = \"540ms\""), "{}", lines[2]);
        assert!(lines[3].starts_with("scan_time = \"24ms\""), "{}", lines[3]);
        assert_eq!(lines[4], "[robots.press-loader.motion]");
        assert_eq!(
            lines[5],
            "frequency_model = \"fpx-divider\"  # fits on channels 0, 1 (1878 Hz ran at \
             1842.60 Hz on channel 0)"
        );
    }

    #[test]
    fn modbus_lines_carry_the_sizes_and_disagreeing_channels_keep_the_model() {
        let findings = Findings {
            sizes: vec![sizes("modbus", 100, 100)],
            rates: vec![rate(0, Fit::FpxDivider), rate(1, Fit::Ideal)],
            ..Findings::default()
        };
        let lines = config_lines(&target(Protocol::ModbusTcp), &findings);
        assert!(lines[1].starts_with("modbus_max_read = 100"));
        assert!(lines[2].starts_with("modbus_max_write = 100"));
        assert!(
            lines[4].contains("kept, but the channels disagree"),
            "{}",
            lines[4]
        );
        assert!(config_lines(&target(Protocol::ModbusTcp), &Findings::default()).is_empty());
    }
}
