"""Motor boards without hardware, for tests and for a suite run with no board attached.

The ROSArduinoBridge firmware emulated on a pty (``fishtail-fake-board``), the real firmware in
simavr (``fishtail-avr-board``) and a USB-cable relay that tests unplug; the driver talks to
either as to a real board. Names load their module on first use. Set-up: docs/serial.md.
"""

from typing import TYPE_CHECKING

from fishtail_common.package_front import lazy_exports

__all__ = ["BoardConfig", "FakeBoard", "Firmware", "FirmwareConfig", "SimulatedBoard", "UsbCable"]

_HOMES = {
    "fishtail_boards.avr_board": ("SimulatedBoard",),
    "fishtail_boards.board_firmware": ("Firmware", "FirmwareConfig"),
    "fishtail_boards.board_pty": ("BoardConfig", "FakeBoard"),
    "fishtail_boards.usb_cable": ("UsbCable",),
}
__getattr__ = lazy_exports(__name__, __all__, _HOMES)

if TYPE_CHECKING:
    from fishtail_boards.avr_board import SimulatedBoard
    from fishtail_boards.board_firmware import Firmware, FirmwareConfig
    from fishtail_boards.board_pty import BoardConfig, FakeBoard
    from fishtail_boards.usb_cable import UsbCable
