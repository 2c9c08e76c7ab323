//! What the cycle's controller asks of a running cycle, as a value the runner watches: a stop
//! (now, or at the end of the current step), a pause (at the end of the current step), a resume.

/// The requests outstanding.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) struct Control {
    /// Stop the robot and end the cycle now.
    pub stop_now: bool,
    /// End the cycle at the end of the current step.
    pub stop: bool,
    /// Pause at the end of the current step.
    pub pause: bool,
    /// A hold from outside the PLC (the cell face's move-enable dropped): the robot is being
    /// stopped, the move running ends held and the cycle pauses, with this reason.
    pub hold: Option<&'static str>,
    /// Counts the resumes asked for (a paused or faulted cycle goes on when it grows).
    pub resumes: u64,
    /// With a resume from a fault, the PLC's incident count its fault was cleared at: the cycle
    /// acts under it from then on (an incident since faults it again). A resume from a pause
    /// keeps the count the cycle had.
    pub epoch: Option<u64>,
}
