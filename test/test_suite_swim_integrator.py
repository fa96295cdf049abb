"""The simulator while it compiles its integrator: up at once, saying so, following only after.

A first run after set-up or an upgrade compiles the numba loop for 10-20 s. The node is up
meanwhile, says on the console and in /diagnostics that it is compiling (``integrator``,
``integrator_s`` so far, level OK: nothing is wrong), takes no samples until the loop is ready,
and a second node on the same cache loads it instead of compiling.
"""

from __future__ import annotations

from fishtail_common.interface import MOTOR_JOINT_STATE, Level

SIM_MODULE = "fishtail_swim.nodes.sim_node"
#: A cold compile on a busy 2-core machine, with margin.
COMPILE_TIMEOUT_S = 120.0
START_TIMEOUT_S = 30.0


def integrator_statuses(ros, diagnostics, phase):
    """(level, message, values) of the simulator's statuses with ``integrator`` = ``phase``."""
    found = []
    for _, level, status in ros.statuses(diagnostics, "swim"):
        values = ros.values(status)
        if values.get("integrator") == phase:
            found.append((level, status.message, values))
    return found


def test_first_run_says_it_compiles_then_loads_the_cache(
    start_node, ros, params_file, tmp_path, monkeypatch
):
    # An empty numba cache: the simulator must compile, as on a fresh clone without make setup.
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "numba-cache"))
    diagnostics = ros.record_diagnostics()
    parameters = params_file("oscillatory.yaml")
    first = start_node(SIM_MODULE, name="swim", params_file=parameters)

    ros.spin_until(
        lambda: integrator_statuses(ros, diagnostics, "compiling"),
        START_TIMEOUT_S,
        "a /diagnostics status of the simulator saying it compiles",
    )
    level, message, values = integrator_statuses(ros, diagnostics, "compiling")[0]
    assert level == Level.OK, message
    assert message.startswith("compiling the swimming integrator, ") and "so far" in message
    assert "first run after set-up or an upgrade" in message
    assert float(values["integrator_s"]) >= 0.0 and values["integrator_ready_s"] == ""
    assert values["tf"]  # the usual values are there too
    # No sample is taken while it compiles.
    assert ros.node.count_subscribers(MOTOR_JOINT_STATE.name) == 0

    ros.spin_until(
        lambda: integrator_statuses(ros, diagnostics, "compiled"),
        COMPILE_TIMEOUT_S,
        "the simulator's integrator compiled",
    )
    _, _, values = integrator_statuses(ros, diagnostics, "compiled")[0]
    compile_s = float(values["integrator_ready_s"])
    assert compile_s > 0.0
    ros.wait_for_subscribers(MOTOR_JOINT_STATE.name, 1, START_TIMEOUT_S)
    log = first.stderr()
    assert "compiling the swimming integrator (first run after set-up or an upgrade)" in log, log
    assert "swimming integrator compiled in " in log, log

    # A second simulator on the same cache loads what the first compiled.
    second = start_node(SIM_MODULE, name="swim2", params_file=parameters)
    ros.spin_until(
        lambda: "swimming integrator loaded in " in second.stderr(),
        START_TIMEOUT_S,
        "the second simulator loading its integrator",
    )
    assert "compiling" not in second.stderr(), second.stderr()
