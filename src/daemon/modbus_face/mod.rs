//! The register gateway's Modbus TCP face (`[robots.NAME.gateway.modbus]`): a tokio-modbus server
//! per robot whose every request goes through the robot's [`RobotHandle`] gateway, like the API's:
//! the same access list, the same refusal of the contract's words, the same turn-taking with the
//! worker's motion exchanges. What maps where, and the exceptions, are in `map.rs` (and docs/API.md).
//!
//! ```text
//!  HMI / SCADA --Modbus TCP--> accept: peer in gateway.modbus.allow? (else closed, logged)
//!     --request--> map::ask --Ask--> RobotHandle::{read,write}_registers --> worker --> PLC
//!     <--reply or exception--  map::read_response / map::exception
//!  (a 15 / 16 write tokio-modbus's codec cannot decode is made a write of nothing first,
//!   screen.rs, so it is answered 03 and the connection kept)
//! ```
//! Any unit id is answered: the face stands for one PLC. It ends with the daemon. A robot with a
//! cell face (`[robots.NAME.cell.face]`) has its block here too, from register `registers`
//! (`cell.rs`): those requests go to the face, not the PLC.

mod cell;
mod map;
mod screen;

use std::future::Future;
use std::io;
use std::net::SocketAddr;
use std::pin::Pin;

use tokio::net::{TcpListener, TcpStream};
use tokio_modbus::server::Service;
use tokio_modbus::{ExceptionCode, Request, Response};

use super::RobotHandle;
use crate::gateway::ModbusFace;
use map::Ask;
use screen::{Screened, screened};

/// A robot's Modbus face, bound and waiting to serve.
#[derive(Debug)]
pub struct ModbusFaceServer {
    listener: TcpListener,
    face: ModbusFace,
}

impl ModbusFaceServer {
    /// Binds `face.listen`.
    pub async fn bind(face: &ModbusFace) -> io::Result<Self> {
        let listener = TcpListener::bind(face.listen).await?;
        Ok(Self::on(listener, face))
    }

    /// The face on a listener bound already (tests bind port 0).
    #[must_use]
    pub fn on(listener: TcpListener, face: &ModbusFace) -> Self {
        Self {
            listener,
            face: face.clone(),
        }
    }

    /// Where it listens.
    pub fn local_addr(&self) -> io::Result<SocketAddr> {
        self.listener.local_addr()
    }

    /// Serves `robot`'s gateway until `until` completes (open connections end with it), or the
    /// listener fails.
    pub async fn serve(
        self,
        robot: RobotHandle,
        until: impl Future<Output = ()>,
    ) -> io::Result<()> {
        let face = self.face;
        let name = robot.robot().name.clone();
        let on_connected = |stream: TcpStream, peer: SocketAddr| {
            let admitted = admit(&face, &name, stream, peer).map(|stream| {
                (
                    FaceService {
                        robot: robot.clone(),
                    },
                    stream,
                )
            });
            std::future::ready(Ok(admitted))
        };
        let failed = {
            let name = name.clone();
            move |e: io::Error| {
                tracing::warn!(robot = %name, error = %e, "Modbus face connection failed");
            }
        };
        let server = tokio_modbus::server::tcp::Server::new(self.listener);
        tokio::select! {
            served = server.serve(&on_connected, failed) => served,
            () = until => Ok(()),
        }
    }
}

/// The stream, screened (`screen.rs`), if `peer` may use the face; else none (the connection is
/// closed at once), logged.
fn admit(
    face: &ModbusFace,
    robot: &str,
    stream: TcpStream,
    peer: SocketAddr,
) -> Option<Screened<TcpStream>> {
    if !face.admits(peer.ip()) {
        tracing::warn!(
            robot,
            %peer,
            "Modbus client refused: not in gateway.modbus.allow; connection closed"
        );
        return None;
    }
    tracing::info!(robot, %peer, "Modbus client connected");
    let _ = stream.set_nodelay(true);
    Some(screened(stream))
}

/// The tokio-modbus service of one connection: the robot's gateway.
#[derive(Debug, Clone)]
struct FaceService {
    robot: RobotHandle,
}

type Answer = Pin<Box<dyn Future<Output = Result<Response, ExceptionCode>> + Send>>;

impl Service for FaceService {
    type Request = Request<'static>;
    type Response = Response;
    type Exception = ExceptionCode;
    type Future = Answer;

    fn call(&self, request: Request<'static>) -> Answer {
        let robot = self.robot.clone();
        Box::pin(async move { answer(&robot, &request).await })
    }
}

/// Carries out one request through the robot's gateway.
async fn answer(robot: &RobotHandle, request: &Request<'_>) -> Result<Response, ExceptionCode> {
    let refused = |e: super::GatewayError| {
        let code = map::exception(&e);
        tracing::info!(robot = %robot.robot().name, ?request, exception = u8::from(code), error = %e, "Modbus request refused");
        code
    };
    // A face mirrored in the PLC is the PLC's words' only: not served here too.
    let base = robot
        .face_settings()
        .filter(|f| f.plc.is_none())
        .map(|f| f.registers);
    if let Some(asked) = base.and_then(|base| cell::ask(request, base)) {
        return face(robot, asked?).await;
    }
    match map::ask(request)? {
        Ask::Read { start, count, kind } => {
            let values = robot.read_registers(start, count).await.map_err(refused)?;
            map::read_response(kind, values)
        }
        Ask::Write {
            start,
            values,
            echo,
        } => {
            tracing::info!(robot = %robot.robot().name, address = %start, count = values.len(), "register write (Modbus)");
            robot
                .write_registers(start, values)
                .await
                .map_err(refused)?;
            Ok(echo)
        }
    }
}

/// Carries out one request for the cell face's block.
async fn face(robot: &RobotHandle, asked: cell::FaceAsk) -> Result<Response, ExceptionCode> {
    match asked {
        cell::FaceAsk::Read {
            offset,
            count,
            kind,
        } => {
            let block = robot
                .face_block()
                .ok_or(ExceptionCode::IllegalDataAddress)?;
            Ok(cell::read_response(
                kind,
                block[offset..offset + count].to_vec(),
            ))
        }
        cell::FaceAsk::Write {
            offset,
            values,
            echo,
        } => {
            if robot.face_write(offset, &values).await {
                Ok(echo)
            } else {
                Err(ExceptionCode::IllegalDataAddress)
            }
        }
    }
}
