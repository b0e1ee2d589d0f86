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
import sys

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

EXTENSION = "ltvmodels.core.precompiled_kernels"


class BuildPrecompiled(build_ext):
    """Builds the precompiled kernels by numba.pycc (not from C sources), or leaves them out."""

    def run(self) -> None:
        # into the build directory (setuptools copies it to the sources for an editable
        # install): build_ext.run() builds there, whatever self.inplace says
        inplace, self.inplace = self.inplace, False
        for ext in [ext for ext in self.extensions if ext.name == EXTENSION]:
            if not self.build_precompiled(self.get_ext_fullpath(ext.name)):
                self.extensions.remove(ext)  # nothing to copy or install
        self.inplace = inplace
        super().run()

    def build_extension(self, ext: Extension) -> None:
        if ext.name != EXTENSION:  # built by run()
            super().build_extension(ext)

    @staticmethod
    def build_precompiled(target: str) -> bool:
        """Compile the kernels into the file ``target``; False (and why) where that fails."""
        if os.environ.get("LTVMODELS_PRECOMPILED", "1") == "0":
            print("the precompiled kernels are left out (LTVMODELS_PRECOMPILED=0)")
            return False
        sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "src"))
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
        finally:
            sys.path.pop(0)


setup(
    ext_modules=[Extension(EXTENSION, sources=[])],
    cmdclass={"build_ext": BuildPrecompiled},
)
