"""The build's one step beyond pyproject.toml: the kernels compiled ahead of time.

``ltvmodels.core.precompiled_kernels`` is an extension module that numba.pycc
compiles from the signatures in ``src/ltvmodels/core/precompiled.json`` (see
:mod:`ltvmodels.core.precompiled`). It is optional: where it cannot be built
(no C compiler, a numba without pycc) the package is installed without it and
its kernels compile at first use, as numba does. ``LTVMODELS_PRECOMPILED=0``
in the environment leaves it out on purpose (a faster install where the kernels
will not be used).
"""

import os
import subprocess
import sys

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

EXTENSION = "ltvmodels.core.precompiled_kernels"


class BuildPrecompiled(build_ext):
    """Builds the precompiled kernels by numba.pycc (not from C sources), or leaves them out."""

    def run(self) -> None:
        for ext in [ext for ext in self.extensions if ext.name == EXTENSION]:
            # an editable install whose extension in the sources is current keeps it
            # (no minute of compilation, no rewrite of a file an interpreter may hold)
            if self.inplace and self.with_sources(self.current, self.get_ext_fullpath(ext.name)):
                self.extensions.remove(ext)
                continue
            # into the build directory (setuptools copies it to the sources for an
            # editable install): build_ext.run() builds there, whatever self.inplace says
            inplace, self.inplace = self.inplace, False
            if not self.with_sources(self.build_precompiled, self.get_ext_fullpath(ext.name)):
                self.extensions.remove(ext)  # nothing to copy or install
            self.inplace = inplace
        super().run()

    def build_extension(self, ext: Extension) -> None:
        if ext.name != EXTENSION:  # built by run()
            super().build_extension(ext)

    @staticmethod
    def with_sources(step, target: str) -> bool:
        """``step(target)`` with this checkout's ``src`` importable."""
        sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "src"))
        try:
            return step(target)
        finally:
            sys.path.pop(0)

    @staticmethod
    def current(path: str) -> bool:
        """Whether ``path`` holds the extension built from these sources (asked of another
        interpreter: one that loaded the file must not see it rewritten)."""
        if not os.path.exists(path):
            return False
        check = (
            "import sys; sys.path.insert(0, sys.argv[2]); "
            "from ltvmodels.core.precompiled import built_stamp, source_stamp; "
            "sys.exit(built_stamp(sys.argv[1]) != source_stamp())"
        )
        run = subprocess.run(
            [sys.executable, "-c", check, path, sys.path[0]],
            capture_output=True,
            text=True,
            timeout=300,
        )
        if run.returncode != 0:
            print(f"the precompiled kernels in {path} are rebuilt: {run.stderr or 'stale'}")
        return run.returncode == 0

    @staticmethod
    def build_precompiled(target: str) -> bool:
        """Compile the kernels into the file ``target``; False (and why) where that fails."""
        if os.environ.get("LTVMODELS_PRECOMPILED", "1") == "0":
            print("the precompiled kernels are left out (LTVMODELS_PRECOMPILED=0)")
            return False
        try:
            from ltvmodels.core.precompiled import build

            build(os.path.dirname(target), os.path.basename(target))
            return True
        except Exception as error:  # optional: the kernels then compile at first use
            print(
                f"warning: the precompiled kernels were not built ({error!r}); ltvmodels "
                "works without them, its kernels compile at first use"
            )
            return False


setup(
    ext_modules=[Extension(EXTENSION, sources=[])],
    cmdclass={"build_ext": BuildPrecompiled},
)
