"""The real firmware and its simulator for the tests: built once by set-up, never by a test.

``make test`` runs tools/test-firmware.sh (firmware/build.sh) before pytest. Where it could not
build (no AVR toolchain or simavr, no sketch) it keeps the build's one-line reason in
:data:`SKIP_REASON`, and the tests that need the firmware skip with it.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from fishtail_boards.avr_board import BUILD_DIR, ELF_NAME, SIMULATOR_NAME, built_artifacts

ROOT = Path(__file__).resolve().parents[3]
#: Where set-up builds the firmware ELF and the simulator.
FIRMWARE_DIR = ROOT / BUILD_DIR
#: The build's one-line reason when set-up could not build (tools/test-firmware.sh writes it).
SKIP_REASON = FIRMWARE_DIR / "skip-reason.txt"


def built_firmware_or_skip() -> Path:
    """build/firmware with the ELF and the simulator; skips the test, saying why, without them."""
    if SKIP_REASON.is_file():
        reason = SKIP_REASON.read_text(errors="replace").strip() or "no reason given"
        pytest.skip(f"firmware in simavr: {reason}")
    if built_artifacts(FIRMWARE_DIR) is None:
        pytest.skip(
            f"firmware in simavr: no {ELF_NAME} and {SIMULATOR_NAME} in {BUILD_DIR} "
            "(make test builds them first; alone: make firmware)"
        )
    return FIRMWARE_DIR
