"""What goes onto the fish: the motor driver node and the serial stack beneath it.

The ROSArduinoBridge codec, one serial link, encoder tracking, stamping, the backends (the
plant's simulated motor or the board over serial) and the node (:mod:`fishtail_driver.node`);
no simulator, pilot or board emulation. Names load their module on first use. docs/serial.md.
"""

from typing import TYPE_CHECKING

from fishtail_common.package_front import lazy_exports

__all__ = [
    "CarrierCommand",
    "CommandRefusedError",
    "EncoderTracker",
    "MotorBackend",
    "SerialBackend",
    "SerialConfig",
    "SerialLink",
    "SimBackend",
    "make_backend",
]

_HOMES = {
    "fishtail_driver.backends": ("MotorBackend", "SimBackend"),
    "fishtail_driver.encoder_tracking": ("EncoderTracker",),
    "fishtail_driver.parameters": ("make_backend",),
    "fishtail_driver.profile_command": ("CarrierCommand", "CommandRefusedError"),
    "fishtail_driver.serial_backend": ("SerialBackend",),
    "fishtail_driver.serial_config": ("SerialConfig",),
    "fishtail_driver.serial_link": ("SerialLink",),
}
__getattr__ = lazy_exports(__name__, __all__, _HOMES)

if TYPE_CHECKING:
    from fishtail_driver.backends import MotorBackend, SimBackend
    from fishtail_driver.encoder_tracking import EncoderTracker
    from fishtail_driver.parameters import make_backend
    from fishtail_driver.profile_command import CarrierCommand, CommandRefusedError
    from fishtail_driver.serial_backend import SerialBackend
    from fishtail_driver.serial_config import SerialConfig
    from fishtail_driver.serial_link import SerialLink
