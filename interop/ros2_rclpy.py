"""Real ROS 2 (rclpy on Fast DDS) next to stereocal's nodes, for the checks that test them.

- `DomainLease`: a ROS domain of the interop range (150..=232) that no other leaseholder
  on the machine uses meanwhile. It takes the same lock files as the Rust
  `stereocal_runtime::testing::DomainLease` (`<tempdir>/stereocal-ros-domain-{id}.lock`,
  an exclusive non-blocking flock), so these checks, the measuring tools and `cargo test`
  (domains 20..=119) never see each other's nodes.
- `NodeProcess`: a node executable started on that domain with its stderr collected;
  `stop()` sends SIGTERM and returns the exit code (None when it had to be killed).
- `Peer`: the checks' own rclpy node on that domain, on rmw_fastrtps_cpp (forced and
  asserted), with a context and executor of its own. `wait_until` spins it until a
  condition holds or a deadline passes: deadlines on progress, never fixed sleeps, so a
  loaded machine makes a check slower, not wrong. It also subscribes with a collecting
  callback, calls services and reads the ROS graph.
- `Parameters`: a node's six parameter services (rcl_interfaces list, get, get_types,
  set, set_atomically, describe), called as `ros2 param` calls them, with Python values.
- `Checks`: runs named checks, goes on after a failure, prints the table of (node,
  check, result, seconds) with every failure's reason, and gives the exit status.
"""

import atexit
import fcntl
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
import traceback
from contextlib import contextmanager
from pathlib import Path

# The middleware is chosen when rclpy first initializes a context: force the one users'
# robots run by default, whatever the environment says.
RMW = "rmw_fastrtps_cpp"
os.environ["RMW_IMPLEMENTATION"] = RMW

import rclpy  # noqa: E402
from rcl_interfaces.srv import (  # noqa: E402
    DescribeParameters, GetParameters, GetParameterTypes, ListParameters, SetParameters,
    SetParametersAtomically,
)
from rclpy.context import Context  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.parameter import Parameter, parameter_value_to_python  # noqa: E402
from std_srvs.srv import Trigger  # noqa: E402

#: Domains the interop checks lease: clear of `cargo test`'s 20..=119 and the demo's 77.
INTEROP_DOMAINS = range(150, 233)
#: Default deadline of a wait: generous, as a wait returns as soon as its condition holds.
TIMEOUT_S = 60.0
#: How long a node may take to stop after SIGTERM.
STOP_TIMEOUT_S = 30.0

#: The parameter services every ROS 2 node serves, with their types.
PARAMETER_SERVICES = {
    "describe_parameters": DescribeParameters,
    "get_parameter_types": GetParameterTypes,
    "get_parameters": GetParameters,
    "list_parameters": ListParameters,
    "set_parameters": SetParameters,
    "set_parameters_atomically": SetParametersAtomically,
}


class CheckFailed(Exception):
    """A check found the node doing something else than it should."""


def require(condition, message):
    """Fails the running check with `message` (a string or a callable making one)."""
    if not condition:
        raise CheckFailed(message() if callable(message) else message)


class DomainLease:
    """The first free ROS domain of `domains`, held until `release()` or the process ends."""

    def __init__(self, domains=INTEROP_DOMAINS):
        directory = Path(tempfile.gettempdir())
        for domain in domains:
            try:
                lock = open(directory / f"stereocal-ros-domain-{domain}.lock", "a")
            except OSError:
                continue  # another user's lock file: that domain is theirs
            try:
                fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                lock.close()
                continue
            self.id = domain
            self._lock = lock
            return
        raise RuntimeError(f"every ROS domain of {domains.start}..={domains.stop - 1} is "
                           "leased by another process")

    def release(self):
        self._lock.close()


class NodeProcess:
    """A node executable running on ROS domain `domain`, its stderr collected."""

    def __init__(self, command, domain):
        self.name = Path(command[0]).name
        self.process = subprocess.Popen(
            [str(c) for c in command], env=dict(os.environ, ROS_DOMAIN_ID=str(domain)),
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
        )
        self._stderr = bytearray()
        self._reader = threading.Thread(target=self._collect, daemon=True)
        self._reader.start()
        # A node left running by a check that broke must not outlive the checks.
        atexit.register(self._kill)

    def _kill(self):
        if self.process.poll() is None:
            self.process.kill()
            self.process.wait()

    def _collect(self):
        # Bytes, not text: a character may be split between two reads.
        while chunk := self.process.stderr.read1(4096):
            self._stderr.extend(chunk)

    def logs(self):
        """What the node has written to stderr so far."""
        return self._stderr.decode(errors="replace")

    def panic(self):
        """The first lines of the first panic the node logged (a thread of it, such as
        its DDS event loop, died), or None."""
        logs = self.logs()
        at = logs.find("panicked at")
        if at < 0:
            return None
        return "\n".join(logs[logs.rfind("\n", 0, at) + 1:].splitlines()[:4])

    def trouble(self):
        """Why the node cannot be answering, if its process shows it: it has exited, or a
        thread of it panicked; else None."""
        code = self.process.poll()
        if code is not None:
            return f"{self.name} exited with code {code}:\n{self.logs()[-3000:]}"
        panic = self.panic()
        return f"{self.name}: {panic}" if panic else None

    def stop(self, timeout=STOP_TIMEOUT_S):
        """SIGTERM, then waits up to `timeout` s; returns the exit code, or None when the
        node did not stop and was killed."""
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
        try:
            code = self.process.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
            code = None
        self._reader.join(timeout=5)
        return code


class Inbox:
    """Messages a subscription has received, in arrival order (the last `keep` of them
    when `keep` is given), and how many."""

    def __init__(self, keep=None):
        self.messages = []
        self.count = 0
        self.keep = keep
        self.subscription = None

    def __call__(self, message):
        self.count += 1
        self.messages.append(message)
        if self.keep is not None and len(self.messages) > self.keep:
            del self.messages[0]

    @property
    def last(self):
        return self.messages[-1] if self.messages else None


class Peer:
    """The checks' rclpy node `namespace/name` on ROS domain `domain`, on Fast DDS.

    `socket_buffer` (bytes; None keeps Fast DDS's default, the OS's 208 KiB) is the size
    of Fast DDS's UDP socket buffers, asked for with FASTDDS_BUILTIN_TRANSPORTS unless
    that is set already, and capped by the kernel at net.core.rmem_max/wmem_max. It is
    read when the process's first participant is made. RustDDS sends a sample as one
    burst of datagrams: a multi-megabyte image overflows a default-sized buffer, and the
    image is then lost to a best-effort subscriber and slowly repaired for a reliable
    one. The nodes ask for 8 MiB themselves (STEREOCAL_DDS_RECEIVE_BUFFER)."""

    def __init__(self, domain, name="stereocal_interop", namespace="/interop",
                 socket_buffer=8 * 1024 * 1024):
        if socket_buffer:
            os.environ.setdefault("FASTDDS_BUILTIN_TRANSPORTS",
                                  f"DEFAULT?sockets_size={socket_buffer}")
        self.domain = domain
        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain)
        identifier = rclpy.get_rmw_implementation_identifier()
        if identifier != RMW:
            raise RuntimeError(f"rclpy runs on {identifier}, not {RMW}")
        self.rmw = identifier
        self.node = rclpy.create_node(name, namespace=namespace, context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._clients = {}
        self.watched = []

    def close(self):
        self.executor.shutdown()
        self.node.destroy_node()
        self.context.try_shutdown()

    def wait_until(self, condition, what, timeout=TIMEOUT_S):
        """Spins until `condition()` is truthy and returns its value; fails the check
        with "timed out waiting for `what`" (a string or a callable making one) after
        `timeout` s, or as soon as a watched node process has exited. The failure says
        what the watched processes show (an exit, a panicked thread)."""
        deadline = time.monotonic() + timeout
        while True:
            value = condition()
            if value:
                return value
            exited = any(p.process.poll() is not None for p in self.watched)
            if exited or time.monotonic() > deadline:
                detail = what() if callable(what) else what
                troubles = [t for t in (p.trouble() for p in self.watched) if t]
                raise CheckFailed(
                    ("gave up" if exited else f"timed out after {timeout:.0f} s")
                    + f" waiting for {detail}" + "".join(f"\n{t}" for t in troubles))
            self.executor.spin_once(timeout_sec=0.05)

    def watch(self, process):
        """Makes every wait fail at once when `process` exits, and every failed wait
        report what its stderr shows went wrong."""
        self.watched.append(process)

    def send_until(self, send, condition, what, every=3.0, timeout=TIMEOUT_S):
        """Calls `send()`, and again every `every` s while `condition()` does not hold
        (inputs are often best-effort: a lost message is sent again); returns the
        condition's value, failing like `wait_until` after `timeout` s."""
        next_send = 0.0

        def sent_or_done():
            nonlocal next_send
            value = condition()
            if not value and time.monotonic() >= next_send:
                send()
                next_send = time.monotonic() + every
            return value
        return self.wait_until(sent_or_done, what, timeout)

    def subscribe(self, msg_type, topic, qos, keep=None):
        """An `Inbox` collecting what a new subscription to `topic` receives."""
        inbox = Inbox(keep)
        inbox.subscription = self.node.create_subscription(msg_type, topic, inbox, qos)
        return inbox

    def call(self, client, request, timeout=TIMEOUT_S):
        """Calls a service once its server is discovered; returns the response."""
        self.wait_until(client.service_is_ready, f"a server of {client.srv_name}", timeout)
        future = client.call_async(request)
        self.wait_until(future.done, f"the answer of {client.srv_name}", timeout)
        return future.result()

    def trigger(self, service, timeout=TIMEOUT_S):
        """Calls the std_srvs/Trigger service `service`; returns the response."""
        if service not in self._clients:
            self._clients[service] = self.node.create_client(Trigger, service)
        return self.call(self._clients[service], Trigger.Request(), timeout)

    def node_names(self):
        """(name, namespace) of every node in the graph."""
        return set(self.node.get_node_names_and_namespaces())

    def entities_of(self, name, namespace):
        """{"publishers"|"subscribers"|"services"|"clients": {topic: [types]}} of a node."""
        queries = {
            "publishers": self.node.get_publisher_names_and_types_by_node,
            "subscribers": self.node.get_subscriber_names_and_types_by_node,
            "services": self.node.get_service_names_and_types_by_node,
            "clients": self.node.get_client_names_and_types_by_node,
        }
        return {kind: {topic: sorted(types) for topic, types in query(name, namespace)}
                for kind, query in queries.items()}


class Parameters:
    """The parameter services of the node `node` (fully qualified name), called by `peer`."""

    def __init__(self, peer, node):
        self.peer = peer
        self.node = node
        self.clients = {service: peer.node.create_client(srv, f"{node}/{service}")
                        for service, srv in PARAMETER_SERVICES.items()}

    def _call(self, service, **fields):
        srv = PARAMETER_SERVICES[service]
        return self.peer.call(self.clients[service], srv.Request(**fields))

    def list(self, prefixes=(), depth=0):
        """ListParameters: (sorted names, sorted prefixes)."""
        result = self._call("list_parameters", prefixes=list(prefixes), depth=depth).result
        return sorted(result.names), sorted(result.prefixes)

    def get(self, names):
        """GetParameters: the values as Python values (None for a parameter not set)."""
        values = self._call("get_parameters", names=list(names)).values
        return [parameter_value_to_python(v) for v in values]

    def get_types(self, names):
        """GetParameterTypes: rcl_interfaces/ParameterType constants."""
        return list(self._call("get_parameter_types", names=list(names)).types)

    def set(self, values):
        """SetParameters with {name: Python value}: one SetParametersResult each."""
        return list(self._call("set_parameters", parameters=messages(values)).results)

    def set_atomically(self, values):
        """SetParametersAtomically with {name: Python value} or [(name, value), ...]
        (a name may then come twice): one SetParametersResult."""
        return self._call("set_parameters_atomically", parameters=messages(values)).result

    def describe(self, names):
        """DescribeParameters: one ParameterDescriptor per name."""
        return list(self._call("describe_parameters", names=list(names)).descriptors)


def messages(values):
    """rcl_interfaces/Parameter messages of {name: Python value} or [(name, value), ...]."""
    pairs = values.items() if isinstance(values, dict) else values
    return [Parameter(name, value=value).to_parameter_msg() for name, value in pairs]


#: A rcl_interfaces/ParameterValue as a Python value (None when not set).
python_value = parameter_value_to_python


class Checks:
    """Named checks with their results and durations; see `table()`."""

    def __init__(self):
        self.rows = []
        self.started = time.monotonic()

    @contextmanager
    def check(self, node, name):
        """Runs the block as the check `name` of `node`: an exception fails it (and is
        recorded, not raised), so the checks after it still run. The block gets a
        function that notes what a passing check measured, printed beside its result."""
        started = time.monotonic()
        notes = []
        try:
            yield notes.append
        except CheckFailed as e:
            self._record(node, name, "FAIL", started, str(e))
        except Exception:  # a broken check is a failure too, with its traceback
            self._record(node, name, "FAIL", started, traceback.format_exc().rstrip())
        else:
            self._record(node, name, "ok", started, "; ".join(notes))

    def skip(self, node, name, reason):
        self.rows.append((node, name, "skip", 0.0, reason))

    def passed(self, node, name):
        """Whether the check `name` of `node` ran and passed."""
        return any(r[0] == node and r[1] == name and r[2] == "ok" for r in self.rows)

    def _record(self, node, name, result, started, detail):
        seconds = time.monotonic() - started
        self.rows.append((node, name, result, seconds, detail))
        print(f"{result:4} {node}: {name} ({seconds:.1f} s){': ' + detail if detail else ''}",
              flush=True)

    def table(self):
        """Prints the table of checks, every failure's reason and the total time;
        returns the exit status: 0 when no check failed."""
        widths = [max([len(h)] + [len(r[i]) for r in self.rows])
                  for i, h in enumerate(("node", "check", "result"))]
        line = f"{{:{widths[0]}}}  {{:{widths[1]}}}  {{:{widths[2]}}}  {{:>8}}"
        print()
        print(line.format("node", "check", "result", "seconds"))
        print(line.format(*("-" * w for w in widths), "-" * 8))
        for node, name, result, seconds, _ in self.rows:
            print(line.format(node, name, result, f"{seconds:.1f}"))
        failed = [r for r in self.rows if r[2] == "FAIL"]
        skipped = [r for r in self.rows if r[2] == "skip"]
        for node, name, result, _, detail in failed + skipped:
            print(f"\n{result} {node}: {name}\n  " + detail.replace("\n", "\n  "))
        total = time.monotonic() - self.started
        print(f"\n{len(self.rows) - len(failed) - len(skipped)} passed, {len(failed)} failed, "
              f"{len(skipped)} skipped in {total:.1f} s")
        return 1 if failed else 0


def stop_and_check(checks, peer, process, node, name, namespace):
    """SIGTERM `process`: it must exit with 0 within `STOP_TIMEOUT_S`, having logged no
    panic on the way, and the node (`name` in `namespace`) must leave the ROS graph.
    Recorded as the check "clean shutdown" of `node`; returns the node's stderr."""
    if process in peer.watched:
        peer.watched.remove(process)
    with checks.check(node, "clean shutdown (SIGTERM)"):
        early = process.process.poll()
        require(early is None, lambda: f"{process.name} had exited with code {early} before "
                f"SIGTERM:\n{process.logs()[-3000:]}")
        code = process.stop()
        require(code == 0, lambda: (
            f"{process.name} exit code {code} after SIGTERM" if code is not None
            else f"{process.name} did not stop within {STOP_TIMEOUT_S:.0f} s of SIGTERM: killed")
            + "\n" + process.logs()[-3000:])
        panic = process.panic()
        require(panic is None, lambda: f"{process.name} exited with 0, but a thread of it "
                f"panicked while it ran:\n{panic}")
        peer.wait_until(lambda: (name, namespace) not in peer.node_names(),
                        f"{namespace}/{name} to leave the ROS graph")
    return process.logs()


def main_guard(run):
    """Runs `run(checks)`, prints the table and exits with its status (1 as well when
    `run` itself broke)."""
    checks = Checks()
    broken = False
    try:
        run(checks)
    except Exception:
        traceback.print_exc()
        broken = True
    sys.exit(checks.table() or int(broken))
