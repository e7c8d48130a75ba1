"""The candp2 Python package; metadata in setup.cfg (pip install ./python works offline with
Debian's setuptools: no build isolation, nothing to download).

setuptools builds in the source tree by default (build/, candp2.egg-info): here every command
builds in a scratch folder removed when it ends, so `pip install ./python` (and `pip wheel`)
leave the checkout as it was. A folder given on the command line (pip's own --egg-base for the
metadata) still wins."""

import atexit
import os
import shutil
import tempfile

from setuptools import setup

scratch = tempfile.mkdtemp(prefix="candp2-setup-")
atexit.register(shutil.rmtree, scratch, True)

setup(options={"build": {"build_base": os.path.join(scratch, "build")},
               "egg_info": {"egg_base": scratch}})
