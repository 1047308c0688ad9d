//! The USB task: a CDC-ACM serial port. Frames out (from [`crate::frames::FRAMES_OUT`]), commands in.
//!
//! Nothing here can stall sampling: producers queue frames with `try_send` and count what does not fit; a host
//! that is absent or reads slowly only fills that queue. On each connection the hello frame goes out first.

use embassy_futures::join::join3;
use embassy_stm32::peripherals::USB_OTG_FS;
use embassy_stm32::usb::Driver;
use embassy_usb::class::cdc_acm::{CdcAcmClass, Receiver, Sender, State};
use embassy_usb::driver::EndpointError;
use embassy_usb::Builder;
use octavar_shared::proto::{Command, Decoder};
use static_cell::StaticCell;

use crate::board::{Irqs, UsbParts};
use crate::characterize::{hello, COMMANDS};
use crate::frames::{self, FRAMES_OUT};
use crate::store::LOG_READ;

/// The USB driver of this board.
pub type UsbDriver = Driver<'static, USB_OTG_FS>;

/// Full-speed bulk packets, bytes.
const PACKET: usize = 64;

/// The host went away (or the endpoint was disabled): a normal end of a session.
struct Disconnected;

impl From<EndpointError> for Disconnected {
    fn from(_: EndpointError) -> Self {
        Disconnected
    }
}

/// Runs the USB device, sends frames and receives commands.
#[embassy_executor::task]
pub async fn usb_task(parts: UsbParts) {
    static EP_OUT: StaticCell<[u8; 128]> = StaticCell::new();
    static CONFIG_DESC: StaticCell<[u8; 128]> = StaticCell::new();
    static BOS_DESC: StaticCell<[u8; 64]> = StaticCell::new();
    static CONTROL: StaticCell<[u8; 64]> = StaticCell::new();
    static STATE: StaticCell<State> = StaticCell::new();

    let mut config = embassy_stm32::usb::Config::default();
    // Bus-powered by the host on the bench; a self-powered build would wire VBUS to PA9 and enable this.
    config.vbus_detection = false;
    let driver = Driver::new_fs(parts.otg, Irqs, parts.dp, parts.dm, EP_OUT.init([0; 128]), config);

    let mut usb_config = embassy_usb::Config::new(0x1209, 0x0001);
    usb_config.manufacturer = Some("octavar");
    usb_config.product = Some("octavar gyro characteriser");
    usb_config.serial_number = Some(env!("CARGO_PKG_VERSION"));

    let mut builder = Builder::new(
        driver,
        usb_config,
        CONFIG_DESC.init([0; 128]),
        BOS_DESC.init([0; 64]),
        &mut [],
        CONTROL.init([0; 64]),
    );
    let class = CdcAcmClass::new(&mut builder, STATE.init(State::new()), PACKET as u16);
    let mut device = builder.build();
    let (mut tx, mut rx) = class.split();

    let send = async {
        loop {
            tx.wait_connection().await;
            defmt::info!("usb: connected");
            frames::send(&hello());
            let _ = pump(&mut tx).await;
            defmt::info!("usb: disconnected");
        }
    };
    let receive = async {
        loop {
            rx.wait_connection().await;
            let _ = listen(&mut rx).await;
        }
    };
    join3(device.run(), send, receive).await;
}

/// Send queued frames in full-speed packets; a frame that is a multiple of 64 bytes ends with a zero-length
/// packet so the host's read completes.
async fn pump(tx: &mut Sender<'static, UsbDriver>) -> Result<(), Disconnected> {
    loop {
        let frame = FRAMES_OUT.receive().await;
        for chunk in frame.chunks(PACKET) {
            tx.write_packet(chunk).await?;
        }
        if frame.len() % PACKET == 0 {
            tx.write_packet(&[]).await?;
        }
    }
}

/// Decode commands and route them: field-log reads to the store task, the rest to characterize.
async fn listen(rx: &mut Receiver<'static, UsbDriver>) -> Result<(), Disconnected> {
    let mut decoder = Decoder::<Command>::new();
    let mut buf = [0u8; PACKET];
    loop {
        let n = rx.read_packet(&mut buf).await?;
        for received in decoder.feed(&buf[..n]) {
            match received {
                Ok(r) => route(r.msg),
                Err(e) => defmt::warn!("usb: bad command frame: {}", defmt::Debug2Format(&e)),
            }
        }
    }
}

/// Hand a command to the task that acts on it.
pub fn route(cmd: Command) {
    match cmd {
        Command::ReadFieldLog { from_checkpoint } => LOG_READ.signal(from_checkpoint),
        other => {
            if COMMANDS.try_send(other).is_err() {
                defmt::warn!("usb: command queue full, {} dropped", other);
            }
        }
    }
}
