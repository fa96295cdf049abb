"""Build script of the fishtail_swim ament_python package (built by colcon)."""

from setuptools import find_packages, setup

PACKAGE = "fishtail_swim"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test", "test.*"]),
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="fishtail maintainers",
    maintainer_email="fishtail@example.com",
    description="Planar swimming dynamics of the robotic fish driven by its tail mechanism.",
    license="Apache-2.0",
    tests_require=["pytest"],
    entry_points={
        "console_scripts": [
            "sim = fishtail_swim.nodes.sim_node:main",
            "pilot = fishtail_pilot.node:main",
            "fishtail-swim = fishtail_swim.offline.cli:main",
        ],
    },
)
