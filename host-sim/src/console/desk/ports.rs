//! `ports`: the serial ports this machine has, with their USB identities; ST-LINK virtual COM
//! ports (STMicroelectronics, USB vendor 0483) are marked, since that is the NUCLEO board.

use serialport::{SerialPortInfo, SerialPortType};

use super::DeskError;

/// STMicroelectronics' USB vendor id (the ST-LINK on NUCLEO boards).
pub const ST_VID: u16 = 0x0483;

/// One line describing a port.
pub fn describe(p: &SerialPortInfo) -> String {
    match &p.port_type {
        SerialPortType::UsbPort(u) => {
            let mut s = format!("{}  usb {:04x}:{:04x}", p.port_name, u.vid, u.pid);
            for v in [&u.manufacturer, &u.product, &u.serial_number]
                .into_iter()
                .flatten()
            {
                s.push_str("  ");
                s.push_str(v);
            }
            if u.vid == ST_VID {
                s.push_str("  <- ST-LINK (NUCLEO board)");
            }
            s
        }
        SerialPortType::PciPort => format!("{}  pci", p.port_name),
        SerialPortType::BluetoothPort => format!("{}  bluetooth", p.port_name),
        SerialPortType::Unknown => format!("{}  (no USB identity)", p.port_name),
    }
}

/// List the ports, ST-LINK ones first.
pub fn list() -> Result<Vec<String>, DeskError> {
    let mut ports = serialport::available_ports().map_err(DeskError::Ports)?;
    ports.sort_by_key(|p| {
        let st = matches!(&p.port_type, SerialPortType::UsbPort(u) if u.vid == ST_VID);
        (!st, p.port_name.clone())
    });
    Ok(ports.iter().map(describe).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use serialport::UsbPortInfo;

    #[test]
    fn st_link_is_marked() {
        let p = SerialPortInfo {
            port_name: "/dev/ttyACM0".into(),
            port_type: SerialPortType::UsbPort(UsbPortInfo {
                vid: 0x0483,
                pid: 0x374b,
                serial_number: Some("0669FF".into()),
                manufacturer: Some("STMicroelectronics".into()),
                product: Some("STM32 STLink".into()),
            }),
        };
        let d = describe(&p);
        assert!(
            d.starts_with("/dev/ttyACM0  usb 0483:374b  STMicroelectronics  STM32 STLink  0669FF"),
            "{d}"
        );
        assert!(d.ends_with("ST-LINK (NUCLEO board)"));
        let q = SerialPortInfo {
            port_name: "/dev/ttyS0".into(),
            port_type: SerialPortType::Unknown,
        };
        assert!(!describe(&q).contains("ST-LINK"));
    }
}
