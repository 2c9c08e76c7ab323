//! PURE. A bank's upload cut into exchanges: every write, each at most what one write exchange
//! carries, then (when verifying) every read-back, each at most what one read exchange carries.
//! [`super::Contract::upload_step`] makes one at a time, so that the upload's owner can watch
//! a running move between two of them (a long upload at a slow baud rate lasts seconds).

use crate::contract::CommandBlock;
use crate::plc::ExchangeSizes;

use super::{VerifiedBank, Write};

/// An upload under way: made by [`super::Contract::begin_upload`] or
/// [`super::Contract::begin_upload_preloaded`], carried out by
/// [`super::Contract::upload_step`] until it yields its bank.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Upload {
    block: CommandBlock,
    writes: Vec<Write>,
    on_preload: bool,
    verify: bool,
    /// Reading back (after every write), or writing.
    reading: bool,
    /// The write (or its read-back) under way, and the words of it done.
    index: usize,
    at: usize,
}

/// One exchange of an upload.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) enum Exchange {
    /// Write `words` from `address`.
    Write { address: u16, words: Vec<u16> },
    /// Read back from `address` and compare with `words`.
    ReadBack { address: u16, words: Vec<u16> },
}

impl Upload {
    pub(super) fn new(
        block: CommandBlock,
        writes: Vec<Write>,
        on_preload: bool,
        verify: bool,
    ) -> Self {
        let writes = writes.into_iter().filter(|(_, w)| !w.is_empty()).collect();
        Self {
            block,
            writes,
            on_preload,
            verify,
            reading: false,
            index: 0,
            at: 0,
        }
    }

    /// The next exchange, at most `sizes` words, and the upload moved past it; `None` when
    /// every write (and read-back) is done.
    pub(super) fn next(&mut self, sizes: ExchangeSizes) -> Option<Exchange> {
        if self.index == self.writes.len() && !self.reading && self.verify {
            self.reading = true;
            self.index = 0;
        }
        if self.index == self.writes.len() {
            return None;
        }
        let (address, all) = &self.writes[self.index];
        let most = if self.reading {
            sizes.read_words
        } else {
            sizes.write_words
        };
        let n = usize::from(most.max(1)).min(all.len() - self.at);
        let address = address + self.at as u16;
        let words = all[self.at..self.at + n].to_vec();
        self.at += n;
        if self.at == all.len() {
            self.index += 1;
            self.at = 0;
        }
        Some(if self.reading {
            Exchange::ReadBack { address, words }
        } else {
            Exchange::Write { address, words }
        })
    }

    /// Whether one of its writes begins at `address`.
    pub(super) fn writes_at(&self, address: u16) -> bool {
        self.writes.iter().any(|(a, _)| *a == address)
    }

    /// Whether every exchange is done.
    #[must_use]
    pub fn is_done(&self) -> bool {
        self.index == self.writes.len() && (self.reading || !self.verify)
    }

    /// The bank, once every exchange is done.
    pub(super) fn bank(&self) -> Option<VerifiedBank> {
        self.is_done().then(|| VerifiedBank {
            block: self.block,
            words: self.writes.iter().map(|(_, w)| w.len()).sum(),
            on_preload: self.on_preload,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sizes(write_words: u16, read_words: u16) -> ExchangeSizes {
        ExchangeSizes {
            read_words,
            write_words,
            read_bits: 16,
        }
    }

    fn block_of(writes: &[(u16, usize)]) -> Vec<Write> {
        writes
            .iter()
            .map(|&(a, n)| (a, (0..n as u16).map(|w| a ^ w).collect()))
            .collect()
    }

    /// Every exchange of `up`, in order.
    fn all(up: &mut Upload, s: ExchangeSizes) -> Vec<Exchange> {
        std::iter::from_fn(|| up.next(s)).collect()
    }

    #[test]
    fn every_word_is_written_once_in_order_then_read_back_once_in_order() {
        let writes = block_of(&[(2_000, 50), (4_000, 24), (1_033, 15), (6_000, 0)]);
        for verify in [true, false] {
            let mut up = Upload::new(CommandBlock::default(), writes.clone(), false, verify);
            let s = sizes(24, 27);
            let exchanges = all(&mut up, s);
            assert!(up.is_done());
            let (mut written, mut read) = (Vec::new(), Vec::new());
            for e in &exchanges {
                match e {
                    Exchange::Write { address, words } => {
                        assert!(read.is_empty(), "a write after a read-back");
                        assert!(words.len() <= 24 && !words.is_empty());
                        written.push((*address, words.clone()));
                    }
                    Exchange::ReadBack { address, words } => {
                        assert!(words.len() <= 27 && !words.is_empty());
                        read.push((*address, words.clone()));
                    }
                }
            }
            // Joined back, the exchanges are the writes, word for word, address for address.
            let join = |parts: &[(u16, Vec<u16>)]| {
                let mut out: Vec<(u16, u16)> = Vec::new();
                for (a, words) in parts {
                    out.extend(words.iter().enumerate().map(|(i, w)| (a + i as u16, *w)));
                }
                out
            };
            let expected = join(&writes);
            assert_eq!(join(&written), expected);
            assert_eq!(written.len(), 3 + 1 + 1, "50 words in 3, 24 in 1, 15 in 1");
            if verify {
                assert_eq!(join(&read), expected);
                assert_eq!(read.len(), 2 + 1 + 1);
            } else {
                assert!(read.is_empty());
            }
            let bank = up.bank().unwrap();
            assert_eq!(bank.words, 89);
            assert!(up.next(s).is_none(), "nothing after the end");
        }
    }

    #[test]
    fn nothing_to_write_is_done_at_once() {
        for verify in [true, false] {
            let mut up = Upload::new(
                CommandBlock::default(),
                block_of(&[(2_000, 0)]),
                false,
                verify,
            );
            assert!(up.next(sizes(24, 27)).is_none());
            assert!(up.is_done());
            assert_eq!(up.bank().unwrap().words, 0);
        }
    }

    #[test]
    fn no_bank_before_the_last_exchange() {
        let writes = block_of(&[(2_000, 30), (1_033, 15)]);
        let mut up = Upload::new(CommandBlock::default(), writes, true, true);
        let s = sizes(24, 27);
        let total = {
            let mut probe = up.clone();
            all(&mut probe, s).len()
        };
        for _ in 0..total {
            assert!(up.bank().is_none());
            assert!(up.next(s).is_some());
        }
        assert!(up.bank().unwrap().on_preload);
    }
}
