//! The USB task: a CDC-ACM serial port. Frames out (from [`crate::frames::FRAMES_OUT`]), commands in.
//!
//! Nothing here can stall sampling: producers queue frames with `try_send` and count what does not fit. Frames
//! go out only while the host holds DTR (a terminal program or `octavar record` has the port open). On each
//! such connection the frames queued for nobody are dropped (counted), a lone delimiter ends any fragment the
//! last session left in the FIFO, and the hello goes out first, so the host always starts with a hello. A host
//! that stops reading with DTR still set costs at most [`WRITE_WAIT`] per packet before the frame is dropped,
//! and the queue's producers never wait on it. Each board reports its chip's unique ID as its USB serial number.

use core::sync::atomic::Ordering;

use embassy_futures::join::join3;
use embassy_futures::select::select;
use embassy_stm32::peripherals::USB_OTG_FS;
use embassy_stm32::usb::Driver;
use embassy_time::{with_timeout, Duration};
use embassy_usb::class::cdc_acm::{CdcAcmClass, ControlChanged, Receiver, Sender, State};
use embassy_usb::driver::EndpointError;
use embassy_usb::Builder;
use octavar_shared::proto::{Decoder, RESYNC};
use static_cell::StaticCell;

use crate::board::{Irqs, UsbParts};
use crate::characterize::hello;
use crate::frames::{self, FRAMES_OUT, LINK_UP};

/// The USB driver of this board.
pub type UsbDriver = Driver<'static, USB_OTG_FS>;

/// Full-speed bulk packets, bytes.
const PACKET: usize = 64;
/// The longest one packet may wait for the host before its frame is dropped.
const WRITE_WAIT: Duration = Duration::from_millis(500);

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
    usb_config.serial_number = Some(crate::board::serial_number());

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
    let (mut tx, mut rx, control) = class.split_with_control();

    let send = async {
        loop {
            tx.wait_connection().await;
            while !control.dtr() {
                control.control_changed().await;
            }
            defmt::info!("usb: host connected");
            frames::flush_stale();
            frames::send(&hello());
            LINK_UP.store(true, Ordering::Relaxed);
            let _ = select(pump(&mut tx), dtr_dropped(&control)).await;
            LINK_UP.store(false, Ordering::Relaxed);
            defmt::info!("usb: host gone");
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

/// Wait until the host drops DTR (closes the port).
async fn dtr_dropped(control: &ControlChanged<'static>) {
    while control.dtr() {
        control.control_changed().await;
    }
}

/// Send queued frames in full-speed packets; a frame that is a multiple of 64 bytes ends with a zero-length
/// packet so the host's read completes. A packet the host does not take within [`WRITE_WAIT`] drops its frame.
///
/// An endpoint write returns once its packet is in the TX FIFO, so a frame cut short (a timeout, or the last
/// session's DTR drop) may still reach the host in part. A lone delimiter ([`RESYNC`]) goes out before the first
/// frame of each connection and after every frame not fully sent: the fragment then ends as one bad frame at the
/// host and the next frame (the hello, on a new connection) decodes on its own. Every frame not fully sent is
/// counted in [`frames::FRAMES_DROPPED`].
async fn pump(tx: &mut Sender<'static, UsbDriver>) -> Result<(), Disconnected> {
    let mut resync = true;
    loop {
        let frame = FRAMES_OUT.receive().await;
        if resync {
            match with_timeout(WRITE_WAIT, tx.write_packet(&RESYNC)).await {
                Ok(r) => {
                    if let Err(e) = r {
                        frames::FRAMES_DROPPED.fetch_add(1, Ordering::Relaxed);
                        return Err(e.into());
                    }
                    resync = false;
                }
                Err(_) => {
                    frames::FRAMES_DROPPED.fetch_add(1, Ordering::Relaxed);
                    continue;
                }
            }
        }
        let zlp = frame.len() % PACKET == 0;
        let packets = frame.chunks(PACKET).chain(zlp.then_some(&[][..]));
        for chunk in packets {
            match with_timeout(WRITE_WAIT, tx.write_packet(chunk)).await {
                Ok(Ok(())) => {}
                Ok(Err(e)) => {
                    frames::FRAMES_DROPPED.fetch_add(1, Ordering::Relaxed);
                    return Err(e.into());
                }
                Err(_) => {
                    frames::FRAMES_DROPPED.fetch_add(1, Ordering::Relaxed);
                    resync = true;
                    break;
                }
            }
        }
    }
}

/// Decode commands and route them with their sequence numbers.
async fn listen(rx: &mut Receiver<'static, UsbDriver>) -> Result<(), Disconnected> {
    let mut decoder = Decoder::<octavar_shared::proto::Command>::new();
    let mut buf = [0u8; PACKET];
    loop {
        let n = rx.read_packet(&mut buf).await?;
        for received in decoder.feed(&buf[..n]) {
            match received {
                Ok(r) => crate::commands::route(r.seq, r.msg),
                Err(e) => defmt::warn!("usb: bad command frame: {}", defmt::Debug2Format(&e)),
            }
        }
    }
}
