"""A throwaway PostgreSQL + PostGIS server for tests and benchmarks.

:class:`Cluster` runs ``initdb`` in a new temporary directory, starts
``postgres`` on 127.0.0.1 at a free port (password authentication over TCP,
trust only on its own Unix socket inside the directory), and stops it and
removes the directory on :meth:`Cluster.stop`, also when start-up failed
half-way. Every wait is bounded. PostgreSQL refuses to run as root, so when
this process is root the server runs as the ``postgres`` user (created by the
Debian packages).

Used by the ``postgis_url`` fixture of ``tests/test_postgis.py`` and by
``benchmarks/bench_postgis.py``::

    with Cluster() as cluster:
        url = cluster.create_database("gadb", extensions=("postgis",))

:func:`find_bindir` tells whether the server binaries are installed (Debian:
``apt-get install postgresql-15-postgis-3``); set ``GEOALPHA_PG_BINDIR`` to use
another installation.
"""

from __future__ import annotations

import atexit
import contextlib
import os
import shutil
import signal
import socket
import subprocess
import tempfile
import time
from pathlib import Path

__all__ = ["Cluster", "ClusterError", "find_bindir"]

SUPERUSER = "geoalpha"
PASSWORD = "s3cret-t3st"  # a throwaway server on 127.0.0.1 only
_START_TIMEOUT = 60.0  # seconds
_STOP_TIMEOUT = 30.0
_COMMAND_TIMEOUT = 120.0


class ClusterError(RuntimeError):
    """The throwaway server could not be set up."""


def find_bindir() -> Path | None:
    """Return the directory of ``initdb``/``postgres`` with PostGIS, or None.

    ``GEOALPHA_PG_BINDIR`` wins; otherwise the newest
    ``/usr/lib/postgresql/<version>/bin`` (Debian's layout) whose share
    directory has the PostGIS extension, then ``initdb`` on ``PATH``.
    """
    candidates: list[Path] = []
    if os.environ.get("GEOALPHA_PG_BINDIR"):
        candidates.append(Path(os.environ["GEOALPHA_PG_BINDIR"]))
    versions = sorted(
        Path("/usr/lib/postgresql").glob("*/bin"),
        key=lambda p: int(p.parent.name) if p.parent.name.isdigit() else 0,
        reverse=True,
    )
    candidates.extend(versions)
    on_path = shutil.which("initdb")
    if on_path:
        candidates.append(Path(on_path).resolve().parent)
    for bindir in candidates:
        if (bindir / "initdb").exists() and (bindir / "postgres").exists():
            if _has_postgis(bindir):
                return bindir
    return None


def _has_postgis(bindir: Path) -> bool:
    try:
        share = subprocess.run(
            [str(bindir / "pg_config"), "--sharedir"],
            capture_output=True,
            text=True,
            timeout=30,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        share = f"/usr/share/postgresql/{bindir.parent.name}"
    return (Path(share) / "extension" / "postgis.control").exists()


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


class Cluster:
    """A PostgreSQL server in a temporary directory, on 127.0.0.1.

    Parameters
    ----------
    bindir : path, optional
        Directory of the server binaries; default :func:`find_bindir`.
    settings : dict, optional
        Extra server settings (``-c name=value``), e.g. ``{"work_mem": "64MB"}``.
    """

    def __init__(self, bindir: Path | None = None, settings: dict | None = None):
        self.bindir = Path(bindir) if bindir else find_bindir()
        if self.bindir is None:
            raise ClusterError(
                "no PostgreSQL server with PostGIS found; install it with "
                "'apt-get install postgresql-15-postgis-3' or set GEOALPHA_PG_BINDIR"
            )
        self.settings = dict(settings or {})
        self.port: int | None = None
        self.directory: Path | None = None
        self.process: subprocess.Popen | None = None
        self._as_user: dict = {}

    # -- life cycle ------------------------------------------------------
    def __enter__(self) -> Cluster:
        self.start()
        return self

    def __exit__(self, *exc) -> None:
        self.stop()

    def start(self) -> None:
        """Run initdb and start the server; on any failure, clean up and raise."""
        try:
            self._start()
        except BaseException:
            self.stop()
            raise

    def _start(self) -> None:
        self.directory = Path(tempfile.mkdtemp(prefix="geoalpha-pg-"))
        atexit.register(self.stop)  # also when the caller never reaches stop()
        if os.geteuid() == 0:  # postgres refuses to run as root
            import pwd

            try:
                user = pwd.getpwnam("postgres")
            except KeyError as err:
                raise ClusterError(
                    "running as root needs the 'postgres' user to run the server"
                ) from err
            os.chown(self.directory, user.pw_uid, user.pw_gid)
            self._as_user = {
                "user": user.pw_uid,
                "group": user.pw_gid,
                "extra_groups": [],
                "env": {**os.environ, "HOME": user.pw_dir, "USER": "postgres"},
            }
        self.directory.chmod(0o700)
        pwfile = self.directory / "pwfile"
        pwfile.write_text(PASSWORD + "\n")
        if self._as_user:
            os.chown(pwfile, self._as_user["user"], self._as_user["group"])
        self._run(
            "initdb",
            "-D",
            str(self.datadir),
            "-U",
            SUPERUSER,
            f"--pwfile={pwfile}",
            "--auth-local=trust",
            "--auth-host=scram-sha-256",
            "--encoding=UTF8",
            "--locale=C.UTF-8",
            "--no-sync",
        )
        pwfile.unlink()
        for _attempt in range(3):  # another process may take the port meanwhile
            self.port = _free_port()
            if self._launch():
                return
        raise ClusterError(f"the server did not start; log:\n{self.log_tail()}")

    @property
    def datadir(self) -> Path:
        """The data directory (inside the temporary directory)."""
        assert self.directory is not None
        return self.directory / "data"

    @property
    def logfile(self) -> Path:
        """The server's log file."""
        assert self.directory is not None
        return self.directory / "server.log"

    def log_tail(self, lines: int = 30) -> str:
        """Return the last lines of the server log."""
        try:
            return "\n".join(self.logfile.read_text().splitlines()[-lines:])
        except OSError:
            return "(no log)"

    def _launch(self) -> bool:
        options = {
            "listen_addresses": "127.0.0.1",
            "port": str(self.port),
            "unix_socket_directories": str(self.directory),
            "fsync": "off",
            "synchronous_commit": "off",
            "full_page_writes": "off",
            "max_parallel_workers_per_gather": "0",
            **{k: str(v) for k, v in self.settings.items()},
        }
        args = [str(self.bindir / "postgres"), "-D", str(self.datadir)]
        for name, value in options.items():
            args += ["-c", f"{name}={value}"]
        log = open(self.logfile, "ab")  # closed below
        try:
            self.process = subprocess.Popen(
                args,
                stdin=subprocess.DEVNULL,
                stdout=log,
                stderr=subprocess.STDOUT,
                start_new_session=True,  # a ^C to the tests is not the server's
                **self._as_user,
            )
        finally:
            log.close()
        deadline = time.monotonic() + _START_TIMEOUT
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                self.process = None
                return False  # e.g. the port was taken: try another
            ready = subprocess.run(
                [
                    str(self.bindir / "pg_isready"),
                    "-q",
                    "-h",
                    "127.0.0.1",
                    "-p",
                    str(self.port),
                    "-t",
                    "2",
                ],
                timeout=10,
                check=False,
            )
            if ready.returncode == 0:
                return True
            time.sleep(0.1)
        raise ClusterError(
            f"the server did not accept connections within {_START_TIMEOUT:.0f} s; "
            f"log:\n{self.log_tail()}"
        )

    def stop(self) -> None:
        """Stop the server (fast, then immediate, then kill) and delete its files."""
        process, self.process = self.process, None
        if process is not None and process.poll() is None:
            for sig in (signal.SIGINT, signal.SIGQUIT, signal.SIGKILL):
                with contextlib.suppress(ProcessLookupError):
                    process.send_signal(sig)
                try:
                    process.wait(timeout=_STOP_TIMEOUT)
                    break
                except subprocess.TimeoutExpired:
                    continue
        if self.directory is not None:
            shutil.rmtree(self.directory, ignore_errors=True)
            self.directory = None
        atexit.unregister(self.stop)

    # -- use -------------------------------------------------------------
    def _run(self, program: str, *args: str) -> str:
        try:
            done = subprocess.run(
                [str(self.bindir / program), *args],
                capture_output=True,
                text=True,
                timeout=_COMMAND_TIMEOUT,
                stdin=subprocess.DEVNULL,
                check=False,
                cwd=self.directory,
                **self._as_user,
            )
        except subprocess.TimeoutExpired as err:
            raise ClusterError(f"{program} ran over {_COMMAND_TIMEOUT} s") from err
        if done.returncode != 0:
            raise ClusterError(f"{program} failed: {done.stderr.strip()}")
        return done.stdout

    def psql(self, sql: str, database: str = "postgres") -> str:
        """Run SQL as the superuser over the server's Unix socket; return stdout."""
        return self._run(
            "psql",
            "-X",
            "-q",
            "-A",
            "-t",
            "-v",
            "ON_ERROR_STOP=1",
            "-h",
            str(self.directory),
            "-p",
            str(self.port),
            "-U",
            SUPERUSER,
            "-d",
            database,
            "-c",
            sql,
        )

    def create_database(
        self, name: str, extensions: tuple[str, ...] = ("postgis",)
    ) -> str:
        """Create a database with the given extensions; return its URL (no password).

        The password is :data:`PASSWORD`; pass it in ``PGPASSWORD`` or with
        :meth:`url` ``(password=True)``.
        """
        self.psql(f'CREATE DATABASE "{name}"')
        for extension in extensions:
            self.psql(f'CREATE EXTENSION IF NOT EXISTS "{extension}"', name)
        return self.url(name)

    def url(self, database: str = "postgres", *, password: bool = False) -> str:
        """``postgresql://`` URL of a database, with the password if asked."""
        secret = f":{PASSWORD}" if password else ""
        return f"postgresql://{SUPERUSER}{secret}@127.0.0.1:{self.port}/{database}"
