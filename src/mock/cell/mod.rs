//! PURE. A simulated cell for the mock PLC: the press, the stack of blanks and the sensors around
//! a robot, as simple models of the robot's outputs (Y bits), its channels' counts and time,
//! driving the PLC's inputs (X bits, or R relays) every scan. No IO and no clock: the mock steps
//! it with its own scan time. `linterpd mock-plc --cell FILE` and `linterpd demo --cycle` run
//! `config/examples/cells/press.toml` this way; `linterpd io force` forces an input on a mock.
//!
//! ```text
//! description.rs  the TOML: strict serde (path to a bad key, "did you mean"), then checked
//! when.rs         a sensor's condition on bits (! & | ( ))
//! machine.rs      Cell: step(now_s, what the PLC shows) -> inputs; force and release
//! ```

mod description;
mod machine;
mod when;

pub use description::{
    CellError, Description, Follows, MAX_DURATION_S, MAX_MODELS, MAX_PARTS, Model, Press, Sensor,
    Stack,
};
pub use machine::{Cell, ForceError, Seen};
pub use when::{When, WhenError};
