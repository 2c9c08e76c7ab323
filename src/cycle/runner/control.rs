//! What a cycle's controller asks of it (a stop, a pause, a hold, a resume), as one value the
//! cycle's controller writes and its runner reads; and how a step's motion ended, as the runner
//! takes it.

/// What is asked of the cycle now: one request, the strongest one asked for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Ask {
    /// Nothing: it runs.
    #[default]
    Run,
    /// Pause at the end of the current step.
    Pause,
    /// A hold from outside the PLC (the cell face's move-enable dropped): the robot is being
    /// stopped, the move running ends held and the cycle pauses, with this reason.
    Hold(&'static str),
    /// End the cycle at the end of the current step.
    Stop,
    /// Stop the robot and end the cycle now.
    StopNow,
}

/// The control value a cycle's runner watches.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Control {
    /// What is asked now.
    pub ask: Ask,
    /// Counts the resumes asked for (a paused or faulted cycle goes on when it grows).
    pub resumes: u64,
    /// With a resume from a fault, the PLC's incident count its fault was cleared at: the cycle
    /// acts under it from then on (an incident since faults it again). A resume from a pause
    /// keeps the count the cycle had.
    pub epoch: Option<u64>,
}

impl Control {
    /// A stop is asked for (now, or at the step's end).
    #[must_use]
    pub fn stops(&self) -> bool {
        matches!(self.ask, Ask::Stop | Ask::StopNow)
    }

    /// A stop now is asked for.
    #[must_use]
    pub fn stops_now(&self) -> bool {
        self.ask == Ask::StopNow
    }

    /// The hold from outside the PLC, if one is asked for.
    #[must_use]
    pub fn hold(&self) -> Option<&'static str> {
        match self.ask {
            Ask::Hold(why) => Some(why),
            _ => None,
        }
    }

    /// Why the cycle pauses at the step's end, if it does: a hold's reason, or a pause asked.
    #[must_use]
    pub fn pause(&self) -> Option<&'static str> {
        match self.ask {
            Ask::Pause => Some("paused by request"),
            Ask::Hold(why) => Some(why),
            _ => None,
        }
    }

    /// Whether the cycle runs on as it is (no stop, pause or hold asked).
    #[must_use]
    pub fn runs(&self) -> bool {
        self.ask == Ask::Run
    }

    /// Asks for a stop: at the step's end, or `now`. A stop now stays one.
    pub fn stop(&mut self, now: bool) {
        self.ask = if now || self.ask == Ask::StopNow {
            Ask::StopNow
        } else {
            Ask::Stop
        };
    }

    /// Asks for a pause (a stop, or a hold, asked already stays).
    pub fn pause_asked(&mut self) {
        if self.ask == Ask::Run {
            self.ask = Ask::Pause;
        }
    }

    /// Asks for a hold from outside the PLC (a stop asked already stays).
    pub fn hold_asked(&mut self, why: &'static str) {
        if !self.stops() {
            self.ask = Ask::Hold(why);
        }
    }

    /// Asks for a resume: from a pause, or (`epoch`) from a fault cleared at that incident
    /// count. A stop asked already stays.
    pub fn resume(&mut self, epoch: Option<u64>) {
        if !self.stops() {
            self.ask = Ask::Run;
        }
        self.resumes += 1;
        self.epoch = epoch;
    }
}

/// How a step's motion ended.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum MotionEnd {
    /// Every start of it ended done.
    Done,
    /// The PLC held it (its permit dropped), or a hold from outside the PLC: the robot stands
    /// where it stopped.
    Held {
        /// Which input dropped, or the hold's reason.
        why: String,
    },
    /// It was refused, failed, stopped or cancelled.
    Failed {
        /// Why.
        why: String,
    },
    /// A move prepared ahead was cancelled before its start: nothing moved.
    NotStarted,
    /// A stop asked for now: the robot was stopped.
    StoppedNow,
}

/// How a wait ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WaitEnd {
    /// The condition held.
    Met,
    /// The timeout passed first.
    TimedOut,
    /// A stop asked for (now, or at the step's end: a wait moves nothing, so it ends at once).
    StoppedNow,
    /// A pause asked for: the wait gives way, and is waited again on resume.
    Paused,
}
