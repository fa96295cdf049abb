"""Build script of the fishtail_bringup ament_python package (built by colcon)."""

from glob import glob

from setuptools import find_packages, setup

PACKAGE = "fishtail_bringup"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test", "test.*"]),
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
        (f"share/{PACKAGE}/launch", glob("launch/*.launch.py")),
        # The suite's parameter files and RViz config (the workspace's config/ links here).
        (f"share/{PACKAGE}/config", glob("config/*.yaml") + glob("config/*.rviz")),
        # The motor catalogue and the synthesis' worked problems.
        (f"share/{PACKAGE}/config/motors", glob("config/motors/*.yaml")),
        (f"share/{PACKAGE}/config/design", glob("config/design/*.yaml")),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="fishtail maintainers",
    maintainer_email="fishtail@example.com",
    description="Launch file and supervisor for the fishtail node suite.",
    license="Apache-2.0",
    tests_require=["pytest"],
    entry_points={
        "console_scripts": [
            "fishtail-run = fishtail_bringup.run:main",
            "fishtail-record = fishtail_bringup.record:main",
            "fishtail-view = fishtail_bringup.view:main",
            "fishtail-one-process = fishtail_bringup.one_process:main",
        ],
    },
)
