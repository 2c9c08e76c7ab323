//! PURE. A sensor's condition on bits: signal names or X, Y, R addresses, `!` (not), `&` (all
//! of), `|` (any of), parentheses; `&` binds tighter than `|` (as a cycle's `wait`, without its
//! DT compares: the cell sees bits only).
//!
//! ```text
//!  gripper & !press_go
//!  (X7 | R10) & !X6
//! ```

use thiserror::Error;

use crate::gateway::Address;

/// What is wrong with a condition, naming the word.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum WhenError {
    /// Nothing to decide.
    #[error("is empty: name a bit, e.g. \"gripper & !X6\"")]
    Empty,
    /// A character no condition has.
    #[error("{0:?} is not part of a condition (! & | ( ) and names)")]
    NotUnderstood(char),
    /// A word after a whole condition.
    #[error("{0:?} is not expected there")]
    NotExpected(String),
    /// The text ends where a bit belongs.
    #[error("ends where a bit is expected")]
    EndsEarly,
    /// A `(` with no `)`.
    #[error("has a \"(\" without its \")\"")]
    NotClosed,
    /// A name that is no signal and no bit.
    #[error("{0:?} is neither a signal nor a bit")]
    Unknown(String),
    /// Something else where a bit belongs.
    #[error("{0:?} is where a bit is expected")]
    NotABit(String),
}

/// A parsed condition.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum When {
    /// A bit, on.
    Bit(Address),
    /// Not.
    Not(Box<When>),
    /// All of.
    All(Vec<When>),
    /// Any of.
    Any(Vec<When>),
}

impl When {
    /// Parses `text`, resolving each name with `resolve` (a signal's name or an address).
    ///
    /// # Errors
    /// What is wrong, naming the word.
    pub fn parse(text: &str, resolve: &dyn Fn(&str) -> Option<Address>) -> Result<Self, WhenError> {
        let tokens = tokens(text)?;
        if tokens.is_empty() {
            return Err(WhenError::Empty);
        }
        let mut parser = Parser {
            tokens: &tokens,
            at: 0,
            resolve,
        };
        let when = parser.any()?;
        match parser.tokens.get(parser.at) {
            None => Ok(when),
            Some(t) => Err(WhenError::NotExpected(t.text())),
        }
    }

    /// Whether it holds, each bit read with `bit`.
    pub fn holds(&self, bit: &dyn Fn(Address) -> bool) -> bool {
        match self {
            Self::Bit(a) => bit(*a),
            Self::Not(w) => !w.holds(bit),
            Self::All(ws) => ws.iter().all(|w| w.holds(bit)),
            Self::Any(ws) => ws.iter().any(|w| w.holds(bit)),
        }
    }
}

#[derive(Debug, Clone, PartialEq, Eq)]
enum Token {
    Word(String),
    Not,
    And,
    Or,
    Open,
    Close,
}

impl Token {
    fn text(&self) -> String {
        match self {
            Self::Word(w) => w.clone(),
            Self::Not => "!".into(),
            Self::And => "&".into(),
            Self::Or => "|".into(),
            Self::Open => "(".into(),
            Self::Close => ")".into(),
        }
    }
}

fn tokens(text: &str) -> Result<Vec<Token>, WhenError> {
    let mut out = Vec::new();
    let mut chars = text.chars().peekable();
    while let Some(&c) = chars.peek() {
        let token = match c {
            ' ' | '\t' => {
                chars.next();
                continue;
            }
            '!' => Token::Not,
            '&' => Token::And,
            '|' => Token::Or,
            '(' => Token::Open,
            ')' => Token::Close,
            c if c.is_ascii_alphanumeric() || c == '_' => {
                let mut word = String::new();
                while let Some(&c) = chars
                    .peek()
                    .filter(|c| c.is_ascii_alphanumeric() || **c == '_')
                {
                    word.push(c);
                    chars.next();
                }
                out.push(Token::Word(word));
                continue;
            }
            other => return Err(WhenError::NotUnderstood(other)),
        };
        chars.next();
        out.push(token);
    }
    Ok(out)
}

struct Parser<'t, 'r> {
    tokens: &'t [Token],
    at: usize,
    resolve: &'r dyn Fn(&str) -> Option<Address>,
}

impl Parser<'_, '_> {
    fn next_is(&mut self, token: &Token) -> bool {
        let is = self.tokens.get(self.at) == Some(token);
        if is {
            self.at += 1;
        }
        is
    }

    fn any(&mut self) -> Result<When, WhenError> {
        let mut terms = vec![self.all()?];
        while self.next_is(&Token::Or) {
            terms.push(self.all()?);
        }
        Ok(if terms.len() == 1 {
            terms.remove(0)
        } else {
            When::Any(terms)
        })
    }

    fn all(&mut self) -> Result<When, WhenError> {
        let mut factors = vec![self.factor()?];
        while self.next_is(&Token::And) {
            factors.push(self.factor()?);
        }
        Ok(if factors.len() == 1 {
            factors.remove(0)
        } else {
            When::All(factors)
        })
    }

    fn factor(&mut self) -> Result<When, WhenError> {
        let Some(token) = self.tokens.get(self.at).cloned() else {
            return Err(WhenError::EndsEarly);
        };
        self.at += 1;
        match token {
            Token::Not => Ok(When::Not(Box::new(self.factor()?))),
            Token::Open => {
                let inner = self.any()?;
                if self.next_is(&Token::Close) {
                    Ok(inner)
                } else {
                    Err(WhenError::NotClosed)
                }
            }
            Token::Word(word) => (self.resolve)(&word)
                .map(When::Bit)
                .ok_or(WhenError::Unknown(word)),
            other => Err(WhenError::NotABit(other.text())),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gateway::Area;

    fn resolve(name: &str) -> Option<Address> {
        match name {
            "gripper" => "Y1".parse().ok(),
            other => other.parse().ok(),
        }
    }

    #[test]
    fn and_binds_tighter_than_or_and_not_applies_to_one_bit() {
        let w = When::parse("gripper & !X6 | R10", &resolve).unwrap();
        let on = |bits: &'static [&'static str]| {
            move |a: Address| bits.iter().any(|b| b.parse::<Address>().unwrap() == a)
        };
        assert!(w.holds(&on(&["Y1"])));
        assert!(!w.holds(&on(&["Y1", "X6"])));
        assert!(w.holds(&on(&["X6", "R10"])));
        let grouped = When::parse("gripper & (!X6 | R10)", &resolve).unwrap();
        assert!(!grouped.holds(&on(&["X6", "R10"])));
        assert_eq!(
            When::parse("X5", &resolve).unwrap(),
            When::Bit(Address {
                area: Area::X,
                index: 5
            })
        );
    }

    #[test]
    fn bad_conditions_say_what_is_wrong() {
        let e = |text| When::parse(text, &resolve).unwrap_err().to_string();
        assert!(e("").starts_with("is empty"));
        assert_eq!(e("grip"), "\"grip\" is neither a signal nor a bit");
        assert_eq!(e("X5 &"), "ends where a bit is expected");
        assert_eq!(e("(X5"), "has a \"(\" without its \")\"");
        assert_eq!(e("X5 X6"), "\"X6\" is not expected there");
        assert!(e("X5 == 1").starts_with("'=' is not part of a condition"));
    }
}
