//! SANS-IO. MEWTOCOL-COM, the ASCII protocol of Panasonic PLCs: frames, BCC, typed commands and
//! replies, and the tokio-util codecs that both the host and the mock PLC use.
//!
//! ```text
//!  command:  HEADER STATION '#' TEXT BCC CR
//!  reply ok: HEADER STATION '$' CMD2 DATA BCC [&] CR
//!  reply err:HEADER STATION '!' ERR2 BCC CR
//!  HEADER % (<= 118 chars a frame) or < (<= 2048); STATION 01..99, FF, EE;
//!  BCC = XOR header..last text byte as 2 hex digits, or ** (PLC.md §1)
//! ```
//!
//! # Layout
//! ```text
//! frame.rs    Header, Station, Frame (envelope only), BCC; encoding
//! decoder.rs  FrameDecoder: bytes -> Skipped | Frame, check then parse; shared by both codecs
//! words.rs    word data (4 hex, low byte first) and decimal fields
//! address.rs DtRange, Contact, ContactWords: validated addresses and their text
//! command.rs  Command, Mode; the write-size limit
//! reply.rs    Reply, PlcStatus, Response = Result<Reply, PlcError>; limits
//! multi.rs    multi-frame replies: response_frames (PLC side), ReplyAssembler (host side)
//! codec.rs    ClientCodec and ServerCodec (tokio-util), Addressed, Request, events
//! error.rs    FrameError, MessageError, PlcError (the PLC said no), CodecError
//! ```
//! Nothing here opens a socket or reads a clock.

mod address;
mod codec;
mod command;
mod decoder;
mod error;
mod frame;
mod multi;
mod reply;
mod words;

pub use address::{
    CONTACT_WORD_MAX, CONTACT_WORDS_MAX, Contact, ContactArea, ContactWords, DT_MAX, DtRange,
    SPECIAL_DT,
};
pub use codec::{Addressed, ClientCodec, ClientEvent, Request, ServerCodec, ServerEvent};
pub use command::{Command, Mode, max_write_words};
pub use decoder::{Decoded, FrameDecoder};
pub use error::{CodecError, MessageError, PlcError, PlcErrorCode};
pub use frame::{BccMode, CR, Frame, FrameError, Header, MORE, NO_CHECK, Station, bcc};
pub use multi::{
    Joined, MAX_REPLY_BODY, Progress, ReplyAssembler, ReplyWire, reply_wire, response_frames,
};
pub use reply::{
    PlcStatus, Reply, Response, encode_response, max_read_reply_words, parse_response,
};
pub use words::{dint_to_words, words_to_dint};
