//! Why one of the commission's exchanges with the unit failed. A check that meets one fails and
//! quotes it in what it saw; the procedure itself never returns it.

use thiserror::Error;

use crate::plc::PlcError;
use crate::plc::exchange::ContractError;
use crate::table::TableProblem;

/// A failed exchange (or a table the commission could not build).
#[derive(Debug, Error)]
pub(super) enum Failure {
    /// The contract's exchange failed (the link, or a status block that does not decode).
    #[error("{0:#}")]
    Contract(#[from] ContractError),
    /// A raw read or write failed.
    #[error("{0:#}")]
    Plc(#[from] PlcError),
    /// Fewer words came back than a status block holds.
    #[error("{read} words read")]
    ShortStatus {
        /// How many were read.
        read: usize,
    },
    /// A table the commission built does not validate (a bug, never the unit's fault).
    #[error("the commission's own table is invalid: {}", joined(problems))]
    OwnTable {
        /// What is wrong with it.
        problems: Vec<TableProblem>,
    },
    /// Writing an input relay failed.
    #[error("writing {name} {}: {source:#}", on_off(*on))]
    RelayWrite {
        /// The relay, `R10F`.
        name: String,
        /// What it was written to.
        on: bool,
        /// Why.
        #[source]
        source: PlcError,
    },
    /// A status read after an input relay was written failed.
    #[error("reading the status block after {name}: {source:#}")]
    ReadAfterRelay {
        /// The relay, `R10F`.
        name: String,
        /// Why.
        #[source]
        source: ContractError,
    },
    /// Clear fault was written, and the program stayed out of idle.
    #[error("after clear fault the state is not idle")]
    NotIdleAfterClear,
}

fn joined(problems: &[TableProblem]) -> String {
    let words: Vec<String> = problems.iter().map(ToString::to_string).collect();
    words.join("; ")
}

/// `on` or `off`.
pub(super) fn on_off(on: bool) -> &'static str {
    if on { "on" } else { "off" }
}
