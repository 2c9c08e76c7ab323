//! IO. [`AnyPlc`], the client a `[robots.NAME.plc]` section names, and [`connect`], which opens
//! its link.

use super::link::{BoxedLink, open_serial, open_tcp};
use super::mewtocol::{MewtocolClient, MewtocolOptions};
use super::modbus::{ModbusClient, ModbusOptions};
use super::settings::{LinkSettings, Protocol, Transport};
use super::{ExchangeSizes, Plc, PlcError, PlcMode};
use crate::gateway::Area;

/// One of the PLC clients over an opened link; implements [`Plc`] by delegation.
#[derive(Debug)]
pub enum AnyPlc {
    /// MEWTOCOL-COM.
    Mewtocol(MewtocolClient<BoxedLink>),
    /// Modbus RTU or TCP.
    Modbus(ModbusClient<BoxedLink>),
}

/// Opens the link `settings` describe and puts its protocol's client on it.
pub async fn connect(settings: &LinkSettings) -> Result<AnyPlc, PlcError> {
    let link = match &settings.transport {
        Transport::Serial(serial) => open_serial(serial)?,
        Transport::Tcp(tcp) => open_tcp(tcp).await?,
    };
    Ok(match settings.protocol {
        Protocol::Mewtocol => {
            let options = MewtocolOptions::from_settings(settings)?;
            AnyPlc::Mewtocol(MewtocolClient::new(link, options))
        }
        Protocol::ModbusRtu | Protocol::ModbusTcp => {
            let options = ModbusOptions::from_settings(settings);
            AnyPlc::Modbus(ModbusClient::new(link, options))
        }
    })
}

impl AnyPlc {
    /// Counts the client's retries and timeouts into `counts`, which outlives the client (the
    /// link's owner hands the same counts to every client it opens).
    pub fn set_exchange_counts(&mut self, counts: std::sync::Arc<super::ExchangeCounts>) {
        match self {
            Self::Mewtocol(c) => c.set_exchange_counts(counts),
            Self::Modbus(c) => c.set_exchange_counts(counts),
        }
    }
}

impl Plc for AnyPlc {
    async fn read_words(&mut self, start: u16, count: u16) -> Result<Vec<u16>, PlcError> {
        match self {
            Self::Mewtocol(c) => c.read_words(start, count).await,
            Self::Modbus(c) => c.read_words(start, count).await,
        }
    }

    async fn write_words(&mut self, start: u16, words: &[u16]) -> Result<(), PlcError> {
        match self {
            Self::Mewtocol(c) => c.write_words(start, words).await,
            Self::Modbus(c) => c.write_words(start, words).await,
        }
    }

    async fn write_words_once(&mut self, start: u16, words: &[u16]) -> Result<(), PlcError> {
        match self {
            Self::Mewtocol(c) => c.write_words_once(start, words).await,
            Self::Modbus(c) => c.write_words_once(start, words).await,
        }
    }

    async fn mode(&mut self) -> Result<PlcMode, PlcError> {
        match self {
            Self::Mewtocol(c) => c.mode().await,
            Self::Modbus(c) => c.mode().await,
        }
    }

    async fn read_bits(
        &mut self,
        area: Area,
        start: u32,
        count: u16,
    ) -> Result<Vec<bool>, PlcError> {
        match self {
            Self::Mewtocol(c) => c.read_bits(area, start, count).await,
            Self::Modbus(c) => c.read_bits(area, start, count).await,
        }
    }

    async fn write_bit(&mut self, area: Area, bit: u32, on: bool) -> Result<(), PlcError> {
        match self {
            Self::Mewtocol(c) => c.write_bit(area, bit, on).await,
            Self::Modbus(c) => c.write_bit(area, bit, on).await,
        }
    }

    fn exchange_sizes(&self) -> ExchangeSizes {
        match self {
            Self::Mewtocol(c) => c.exchange_sizes(),
            Self::Modbus(c) => c.exchange_sizes(),
        }
    }
}
