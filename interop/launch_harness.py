"""Evaluates stereocal's ROS 2 launch files without ROS's `launch` packages.

`launch` and `launch_ros` are not on PyPI, so this module stands in for the part of
their API that our launch files use: LaunchDescription, DeclareLaunchArgument,
OpaqueFunction, LaunchConfiguration and launch_ros's Node. Evaluating a launch file
with launch arguments gives the processes `ros2 launch` would start, each turned into
the command line launch_ros builds for it: `<executable> --ros-args -r __node:=<name>
-r __ns:=<namespace> --params-file <file>... -r <from>:=<to>...` (a dictionary of
parameters becomes a params file of its own, as launch_ros writes one).

An action or a launch API this module does not know fails loudly, so a launch file
that grows beyond it is noticed rather than half checked.
"""

import importlib.util
import os
import sys
import types
from contextlib import contextmanager
from dataclasses import dataclass, field

import yaml


class LaunchContext:
    """The launch arguments in force: declared defaults under the caller's values."""

    def __init__(self, arguments):
        self.launch_configurations = dict(arguments)


def perform(value, context):
    """A substitution (or a list of them, or plain text) resolved to text."""
    if isinstance(value, str):
        return value
    if isinstance(value, (list, tuple)):
        return "".join(perform(part, context) for part in value)
    if hasattr(value, "perform"):
        return value.perform(context)
    raise TypeError(f"unsupported substitution {value!r}")


class LaunchConfiguration:
    def __init__(self, name, default=None):
        self.name = name
        self.default = default

    def perform(self, context):
        if self.name in context.launch_configurations:
            return context.launch_configurations[self.name]
        if self.default is not None:
            return perform(self.default, context)
        raise KeyError(f"launch argument {self.name!r} was never declared")


class LaunchDescription:
    def __init__(self, entities=None):
        self.entities = list(entities or [])


class DeclareLaunchArgument:
    def __init__(self, name, default_value=None, description="", choices=None):
        self.name = name
        self.default_value = default_value
        self.description = description
        self.choices = choices


class OpaqueFunction:
    def __init__(self, function, args=None, kwargs=None):
        self.function = function
        self.args = args or []
        self.kwargs = kwargs or {}


class SetEnvironmentVariable:
    def __init__(self, name, value):
        self.name = name
        self.value = value


class Node:
    def __init__(self, executable, name=None, namespace=None, parameters=None, remappings=None,
                 output=None, arguments=None, package=None):
        if package is not None:
            raise ValueError("stereocal nodes are started by executable, not by package")
        self.executable = executable
        self.name = name
        self.namespace = namespace
        self.parameters = parameters or []
        self.remappings = remappings or []
        self.arguments = arguments or []


@dataclass
class NodeLaunch:
    """One process a launch file starts, with everything resolved."""

    executable: str
    name: str
    namespace: str | None
    params_files: list = field(default_factory=list)
    params: dict = field(default_factory=dict)
    remappings: list = field(default_factory=list)
    arguments: list = field(default_factory=list)

    def command(self, workdir):
        """The command line launch_ros builds; dictionary parameters are written to a
        params file in `workdir`."""
        cmd = [self.executable, *self.arguments, "--ros-args"]
        if self.name:
            cmd += ["-r", f"__node:={self.name}"]
        if self.namespace is not None:
            cmd += ["-r", f"__ns:={self.namespace}"]
        for path in self.params_files:
            cmd += ["--params-file", path]
        if self.params:
            stem = f"{(self.namespace or '').strip('/').replace('/', '_')}_{self.name or 'node'}"
            path = os.path.join(workdir, f"{stem}.yaml")
            with open(path, "w") as out:
                yaml.safe_dump({"/**": {"ros__parameters": self.params}}, out)
            cmd += ["--params-file", path]
        for source, target in self.remappings:
            cmd += ["-r", f"{source}:={target}"]
        return cmd


@dataclass
class Evaluation:
    """What evaluating a launch file gave."""

    arguments: dict
    nodes: list
    environment: dict


def _stub_modules():
    launch = types.ModuleType("launch")
    launch.LaunchDescription = LaunchDescription
    actions = types.ModuleType("launch.actions")
    actions.DeclareLaunchArgument = DeclareLaunchArgument
    actions.OpaqueFunction = OpaqueFunction
    actions.SetEnvironmentVariable = SetEnvironmentVariable
    substitutions = types.ModuleType("launch.substitutions")
    substitutions.LaunchConfiguration = LaunchConfiguration
    launch.actions = actions
    launch.substitutions = substitutions
    launch_ros = types.ModuleType("launch_ros")
    ros_actions = types.ModuleType("launch_ros.actions")
    ros_actions.Node = Node
    launch_ros.actions = ros_actions
    return {
        "launch": launch, "launch.actions": actions, "launch.substitutions": substitutions,
        "launch_ros": launch_ros, "launch_ros.actions": ros_actions,
    }


@contextmanager
def overridden(mapping, values):
    """`mapping` (such as sys.modules or os.environ) with `values` set in it, and as it
    was again afterwards."""
    saved = {name: mapping.get(name) for name in values}
    mapping.update(values)
    try:
        yield
    finally:
        for name, original in saved.items():
            if original is None:
                mapping.pop(name, None)
            else:
                mapping[name] = original


def load(path):
    """Imports the launch file at `path` against the stand-in modules."""
    with overridden(sys.modules, _stub_modules()):
        spec = importlib.util.spec_from_file_location(f"launch_file_{abs(hash(path))}", path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module


def _namespace(value, context):
    """The namespace launch_ros passes (None: none, the node keeps its own)."""
    if value is None:
        return None
    text = perform(value, context)
    return text if text.startswith("/") else "/" + text


def evaluate(path, arguments=None):
    """Evaluates the launch file at `path` with `arguments` (name -> text), as
    `ros2 launch <path> name:=value ...` would: every declared argument takes its
    default unless given; an argument that is not declared is an error."""
    description = load(path).generate_launch_description()
    given = dict(arguments or {})
    context = LaunchContext({})
    declared = {}
    nodes = []
    environment = {}

    def run(entities):
        for entity in entities:
            if isinstance(entity, DeclareLaunchArgument):
                declared[entity.name] = entity.description
                if entity.name in given:
                    value = given[entity.name]
                elif entity.default_value is not None:
                    value = perform(entity.default_value, context)
                else:
                    raise ValueError(f"launch argument {entity.name!r} has no default and was not given")
                if entity.choices and value not in entity.choices:
                    raise ValueError(f"launch argument {entity.name}:={value} is not one of {entity.choices}")
                context.launch_configurations[entity.name] = value
            elif isinstance(entity, OpaqueFunction):
                run(entity.function(context, *entity.args, **entity.kwargs) or [])
            elif isinstance(entity, SetEnvironmentVariable):
                environment[perform(entity.name, context)] = perform(entity.value, context)
            elif isinstance(entity, Node):
                launch = NodeLaunch(
                    executable=perform(entity.executable, context),
                    name=perform(entity.name, context) if entity.name is not None else "",
                    namespace=_namespace(entity.namespace, context),
                    remappings=[(perform(a, context), perform(b, context)) for a, b in entity.remappings],
                    arguments=[perform(a, context) for a in entity.arguments],
                )
                for parameters in entity.parameters:
                    if isinstance(parameters, dict):
                        launch.params.update(parameters)
                    else:
                        launch.params_files.append(os.path.normpath(perform(parameters, context)))
                nodes.append(launch)
            else:
                raise TypeError(f"{path}: unsupported launch entity {type(entity).__name__}")

    run(description.entities)
    unknown = set(given) - set(declared)
    if unknown:
        raise ValueError(f"{path}: launch arguments not declared: {sorted(unknown)}")
    return Evaluation(arguments=dict(context.launch_configurations), nodes=nodes, environment=environment)
