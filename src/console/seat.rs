//! PURE. One control seat per robot, and what each role may do.
//!
//! ```text
//!   viewer    sees; stops (a stop works for everyone, in every mode)
//!   operator  + takes the seat; with it: moves, jogs, homes, clears faults, runs cycles, teaches
//!   admin     + deletes positions, changes the mode
//! ```
//! Many sessions watch; one holds the seat, taken explicitly. Taking it from another session
//! ends that one's jog (the console logs the take-over). The seat lives inside local mode: in
//! remote mode the cell face drives the robot, the seat is empty and cannot be taken, and the
//! console only watches, stops, and (an admin) switches back to local.

use serde::Serialize;
use thiserror::Error;

use super::lease::SessionId;
use crate::config::Role;

/// What a session asks to do, as the seat rules tell them apart.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Command {
    /// Read anything.
    View,
    /// Stop the robot.
    Stop,
    /// Take the control seat.
    TakeSeat,
    /// Move, jog, home, clear a fault, run or pause a cycle, teach, set the speed override.
    Operate,
    /// Delete a taught position.
    Delete,
    /// Change the mode (local / remote).
    Mode,
}

/// Who holds a robot's seat.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Holder {
    /// The session.
    #[serde(skip)]
    pub session: SessionId,
    /// Its user.
    pub user: String,
    /// Its role.
    pub role: Role,
}

/// Why a command is refused.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum Refusal {
    /// The role does not allow it.
    #[error("user {user} is {article} {role}: {what} needs the {needs} role", article = article(*role), role = role.name(), needs = needs.name())]
    Role {
        /// The user.
        user: String,
        /// Their role.
        role: Role,
        /// What was asked, in words.
        what: &'static str,
        /// The least role that may.
        needs: Role,
    },
    /// The session does not hold the seat.
    #[error("{what} needs the control seat; {}", holder.as_ref().map_or_else(|| "nobody holds it: take it first".to_owned(), |h| format!("{} holds it: take it over first", h.user)))]
    NoSeat {
        /// What was asked, in words.
        what: &'static str,
        /// Who holds it.
        holder: Option<Holder>,
    },
    /// Remote mode: the cell face drives the robot.
    #[error(
        "{what} is refused in remote mode: the cell face drives the robot (an admin switches to local)"
    )]
    Remote {
        /// What was asked, in words.
        what: &'static str,
    },
}

fn article(role: Role) -> &'static str {
    match role {
        Role::Admin | Role::Operator => "an",
        Role::Viewer => "a",
    }
}

impl Command {
    /// The least role that may do it.
    #[must_use]
    pub fn needs(self) -> Role {
        match self {
            Self::View | Self::Stop => Role::Viewer,
            Self::TakeSeat | Self::Operate => Role::Operator,
            Self::Delete | Self::Mode => Role::Admin,
        }
    }

    /// In words.
    #[must_use]
    pub fn what(self) -> &'static str {
        match self {
            Self::View => "viewing",
            Self::Stop => "stopping",
            Self::TakeSeat => "taking the control seat",
            Self::Operate => "moving the robot",
            Self::Delete => "deleting a position",
            Self::Mode => "changing the mode",
        }
    }
}

/// A robot's control seat.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Seat {
    holder: Option<Holder>,
}

/// A session as the seat sees it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Asker<'a> {
    /// The session.
    pub session: SessionId,
    /// Its user.
    pub user: &'a str,
    /// Its role.
    pub role: Role,
}

impl Seat {
    /// Who holds it.
    #[must_use]
    pub fn holder(&self) -> Option<&Holder> {
        self.holder.as_ref()
    }

    /// Whether `session` holds it.
    #[must_use]
    pub fn held_by(&self, session: SessionId) -> bool {
        self.holder.as_ref().is_some_and(|h| h.session == session)
    }

    /// May `asker` do `command` now (`remote`: the robot is in remote mode)?
    pub fn check(&self, asker: Asker<'_>, command: Command, remote: bool) -> Result<(), Refusal> {
        let needs = command.needs();
        if asker.role < needs {
            return Err(Refusal::Role {
                user: asker.user.to_owned(),
                role: asker.role,
                what: command.what(),
                needs,
            });
        }
        match command {
            Command::View | Command::Stop => Ok(()),
            // An admin switches a remote robot back to local without a seat (there is none).
            Command::Mode if remote => Ok(()),
            _ if remote => Err(Refusal::Remote {
                what: command.what(),
            }),
            Command::TakeSeat => Ok(()),
            _ if self.held_by(asker.session) => Ok(()),
            _ => Err(Refusal::NoSeat {
                what: command.what(),
                holder: self.holder.clone(),
            }),
        }
    }

    /// `asker` takes the seat (from whoever held it); returns the session that lost it, whose
    /// jog must stop.
    pub fn take(&mut self, asker: Asker<'_>, remote: bool) -> Result<Option<Holder>, Refusal> {
        self.check(asker, Command::TakeSeat, remote)?;
        let new = Holder {
            session: asker.session,
            user: asker.user.to_owned(),
            role: asker.role,
        };
        let old = self.holder.replace(new);
        Ok(old.filter(|h| h.session != asker.session))
    }

    /// `session` gives the seat up (or its connection ended): empty if it held it.
    pub fn leave(&mut self, session: SessionId) -> bool {
        if self.held_by(session) {
            self.holder = None;
            true
        } else {
            false
        }
    }

    /// The robot went to remote mode: nobody holds the seat.
    pub fn vacate(&mut self) -> Option<Holder> {
        self.holder.take()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn asker(session: SessionId, user: &'static str, role: Role) -> Asker<'static> {
        Asker {
            session,
            user,
            role,
        }
    }
    fn ann() -> Asker<'static> {
        asker(1, "ann", Role::Operator)
    }
    fn bob() -> Asker<'static> {
        asker(2, "bob", Role::Operator)
    }
    fn vic() -> Asker<'static> {
        asker(3, "vic", Role::Viewer)
    }
    fn ada() -> Asker<'static> {
        asker(4, "ada", Role::Admin)
    }

    #[test]
    fn a_viewer_sees_and_stops_but_cannot_command() {
        let seat = Seat::default();
        assert_eq!(seat.check(vic(), Command::View, false), Ok(()));
        assert_eq!(seat.check(vic(), Command::Stop, false), Ok(()));
        assert_eq!(seat.check(vic(), Command::Stop, true), Ok(()));
        let e = seat.check(vic(), Command::Operate, false).unwrap_err();
        assert_eq!(
            e.to_string(),
            "user vic is a viewer: moving the robot needs the operator role"
        );
        assert!(Seat::default().take(vic(), false).is_err());
    }

    #[test]
    fn an_operator_needs_the_seat_to_move_and_takes_it_explicitly() {
        let mut seat = Seat::default();
        let e = seat.check(ann(), Command::Operate, false).unwrap_err();
        assert_eq!(
            e.to_string(),
            "moving the robot needs the control seat; nobody holds it: take it first"
        );
        assert_eq!(seat.take(ann(), false), Ok(None));
        assert_eq!(seat.check(ann(), Command::Operate, false), Ok(()));
        let e = seat.check(bob(), Command::Operate, false).unwrap_err();
        assert!(e.to_string().contains("ann holds it"), "{e}");
    }

    #[test]
    fn a_take_over_names_the_session_that_lost_the_seat() {
        let mut seat = Seat::default();
        seat.take(ann(), false).unwrap();
        let lost = seat.take(bob(), false).unwrap().unwrap();
        assert_eq!((lost.session, lost.user.as_str()), (1, "ann"));
        assert!(seat.held_by(2) && !seat.held_by(1));
        assert!(seat.check(ann(), Command::Operate, false).is_err());
        // Taking it again when one holds it already loses nobody.
        assert_eq!(seat.take(bob(), false), Ok(None));
    }

    #[test]
    fn deleting_and_the_mode_need_an_admin() {
        let mut seat = Seat::default();
        seat.take(ann(), false).unwrap();
        let e = seat.check(ann(), Command::Delete, false).unwrap_err();
        assert_eq!(
            e.to_string(),
            "user ann is an operator: deleting a position needs the admin role"
        );
        seat.take(ada(), false).unwrap();
        assert_eq!(seat.check(ada(), Command::Delete, false), Ok(()));
        assert_eq!(seat.check(ada(), Command::Mode, false), Ok(()));
    }

    #[test]
    fn remote_mode_has_no_seat_the_console_watches_stops_and_an_admin_switches_back() {
        let mut seat = Seat::default();
        seat.take(ann(), false).unwrap();
        assert_eq!(seat.vacate().map(|h| h.session), Some(1));
        assert!(matches!(
            seat.take(ann(), true),
            Err(Refusal::Remote { .. })
        ));
        assert!(matches!(
            seat.check(ada(), Command::Operate, true),
            Err(Refusal::Remote { .. })
        ));
        assert_eq!(seat.check(vic(), Command::Stop, true), Ok(()));
        assert_eq!(seat.check(ada(), Command::Mode, true), Ok(()));
        assert!(seat.check(ann(), Command::Mode, true).is_err());
    }

    #[test]
    fn leaving_empties_the_seat_only_for_its_holder() {
        let mut seat = Seat::default();
        seat.take(ann(), false).unwrap();
        assert!(!seat.leave(2));
        assert!(seat.leave(1));
        assert_eq!(seat.holder(), None);
    }
}
