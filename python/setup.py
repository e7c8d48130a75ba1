"""The candp2 Python package; metadata in setup.cfg (pip install ./python works offline with
Debian's setuptools: no build isolation, nothing to download)."""

from setuptools import setup

setup()
