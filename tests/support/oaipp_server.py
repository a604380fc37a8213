"""The real oaipp-server for tests written in Python.

    with OaippServer(binary, ["--web_port=8080"]) as server:
        stub = ...(grpc.insecure_channel(server.address))

Starts the binary on a free loopback port with the memory store and no
metrics listener, waits (bounded) until gRPC answers, and stops it on exit.
"""
import os
import socket
import subprocess
import tempfile

START_TIMEOUT_S = 20.0


def free_port():
    """A port that was free on 127.0.0.1 a moment ago."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def stop(process, grace_s=10.0):
    """SIGTERM, then SIGKILL after `grace_s`; None is ignored."""
    if process is None or process.poll() is not None:
        return
    process.terminate()
    try:
        process.wait(timeout=grace_s)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()


class OaippServer:
    def __init__(self, binary, flags=()):
        self.port = free_port()
        self.address = f"127.0.0.1:{self.port}"
        self._args = [binary, f"--listen={self.address}", "--store=memory",
                      "--metrics_listen=", "--log_level=warn", *flags]
        self._log = tempfile.TemporaryFile(mode="w+")
        self._process = None

    def __enter__(self):
        import grpc
        self._process = subprocess.Popen(self._args, stdout=self._log, stderr=subprocess.STDOUT)
        channel = grpc.insecure_channel(self.address)
        try:
            grpc.channel_ready_future(channel).result(timeout=START_TIMEOUT_S)
        except grpc.FutureTimeoutError:
            self.__exit__(None, None, None)
            raise RuntimeError("oaipp-server did not answer within "
                               f"{START_TIMEOUT_S:.0f} s:\n{self.log_tail()}")
        finally:
            channel.close()
        return self

    def __exit__(self, *exc):
        stop(self._process)
        return False

    def log_tail(self, chars=3000):
        self._log.flush()
        self._log.seek(0)
        return self._log.read()[-chars:]
