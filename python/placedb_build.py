"""The build backend of `pip install ./python` (PEP 517, in-tree: pyproject.toml names it).

It configures the project with the system's CMake, builds the module's target (placedb_python,
linked against the system's OpenCV, SQLite, libpq, pybind11 ...) and packs the module into a
wheel for the interpreter that runs it. It needs nothing but the standard library, so pip has no
build dependency to fetch: the install works offline, with or without build isolation.

Config settings (`pip install ./python --config-settings build-dir=DIR`):
  build-dir  a CMake build folder to use and keep (an incremental rebuild next time); default a
             temporary folder, deleted afterwards
  jobs       parallel build jobs (default: the machine's cores)
"""
import base64
import hashlib
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import zipfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _version():
    with open(os.path.join(ROOT, 'CMakeLists.txt')) as f:
        return re.search(r'project\(placedb VERSION ([0-9.]+)', f.read()).group(1)


def _tag():
    """cp311-cp311-linux_x86_64: the module is built for this interpreter and machine only."""
    python = f'cp{sys.version_info[0]}{sys.version_info[1]}'
    platform = sysconfig.get_platform().replace('-', '_').replace('.', '_')
    return f'{python}-{python}-{platform}'


def _metadata():
    return (f'Metadata-Version: 2.1\nName: placedb\nVersion: {_version()}\n'
            'Summary: Appearance-based loop-closure detection with a SQLite map\n'
            'License: BSD-3-Clause\nRequires-Python: >=3.8\nRequires-Dist: numpy\n')


def _dist_info():
    return f'placedb-{_version()}.dist-info'


def get_requires_for_build_wheel(config_settings=None):
    return []


def prepare_metadata_for_build_wheel(metadata_directory, config_settings=None):
    folder = os.path.join(metadata_directory, _dist_info())
    os.makedirs(folder, exist_ok=True)
    with open(os.path.join(folder, 'METADATA'), 'w') as f:
        f.write(_metadata())
    return _dist_info()


def _build_module(build_dir, jobs):
    configure = ['cmake', '-S', ROOT, '-B', build_dir, '-DCMAKE_BUILD_TYPE=Release',
                 '-DPLACEDB_BUILD_TESTS=OFF', '-DPLACEDB_BUILD_BENCH=OFF',
                 '-DPLACEDB_BUILD_PYTHON=ON', f'-DPython_EXECUTABLE={sys.executable}']
    build = ['cmake', '--build', build_dir, '--target', 'placedb_python', '-j', str(jobs)]
    for command in (configure, build):
        print('placedb_build: ' + ' '.join(command), file=sys.stderr, flush=True)
        # pip shows a failed build's output; its own lines go to stderr, as pip expects.
        subprocess.run(command, check=True, stdout=sys.stderr)
    suffix = sysconfig.get_config_var('EXT_SUFFIX')
    module = os.path.join(build_dir, 'python', 'placedb' + suffix)
    if not os.path.exists(module):
        raise RuntimeError(f'placedb_build: the build made no {module}')
    return module


def _record_line(name, data):
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b'=').decode()
    return f'{name},sha256={digest},{len(data)}\n'


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
    settings = config_settings or {}
    jobs = int(settings.get('jobs') or os.cpu_count() or 1)
    kept = settings.get('build-dir')
    build_dir = os.path.abspath(kept) if kept else tempfile.mkdtemp(prefix='placedb-wheel-')
    try:
        module = _build_module(build_dir, jobs)
        with open(module, 'rb') as f:
            binary = f.read()
        with open(os.path.join(ROOT, 'LICENSE'), 'rb') as f:
            license_text = f.read()
    finally:
        if not kept:
            shutil.rmtree(build_dir, ignore_errors=True)
    info = _dist_info()
    files = {
        os.path.basename(module): binary,
        f'{info}/METADATA': _metadata().encode(),
        f'{info}/WHEEL': (f'Wheel-Version: 1.0\nGenerator: placedb_build\nRoot-Is-Purelib: false\n'
                          f'Tag: {_tag()}\n').encode(),
        f'{info}/LICENSE': license_text,
    }
    name = f'placedb-{_version()}-{_tag()}.whl'
    record = ''.join(_record_line(path, data) for path, data in files.items())
    record += f'{info}/RECORD,,\n'
    with zipfile.ZipFile(os.path.join(wheel_directory, name), 'w', zipfile.ZIP_DEFLATED) as wheel:
        for path, data in files.items():
            wheel.writestr(path, data)
        wheel.writestr(f'{info}/RECORD', record)
    return name
