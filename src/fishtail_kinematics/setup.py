"""Build script of the fishtail_kinematics ament_python package (built by colcon)."""

from setuptools import find_packages, setup

PACKAGE = "fishtail_kinematics"

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
    description="Kinematics of the fishtail tail mechanisms, their nodes and command line.",
    license="Apache-2.0",
    tests_require=["pytest"],
    entry_points={
        "console_scripts": [
            "node = fishtail_kinematics.nodes.kinematics_node:main",
            "monitor = fishtail_kinematics.nodes.monitor_node:main",
            "fishtail-kinematics = fishtail_kinematics.offline.cli:main",
            "fishtail-analyse = fishtail_kinematics.offline.analyse_cli:main",
        ],
    },
)
