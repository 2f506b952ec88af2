"""Contact physics: the only module that imports pymunk.

One ``pymunk.Space`` holds every env copy of a batch (copies are placed far apart so they
never touch), which is an order of magnitude faster than one Space per copy
(docs/performance_notes.md). Car velocities come from the numpy dynamics, are written into
pymunk in one batch call, pymunk integrates positions and resolves contacts over its
sub-steps, and the state is read back in one batch call. Contacts are read from pymunk's
arbiters, also in one batch call.

Bodies are added in a fixed order (all cars, env-major, then all obstacles, then all bot
cars) and never removed, so the batch arrays keep that order. Obstacles are kinematic bodies
with zero velocity: they cannot be pushed, and can be moved between episodes in the same batch
call. Bot cars are kinematic car boxes whose velocities the core sets before every step
(:attr:`PhysicsWorld.bot_command`), so pymunk carries them along their scripted path and they
push cars like an unstoppable car would; kinematic bodies never touch each other.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import pymunk
import pymunk.batch as pb
from pymunk._chipmunk_cffi import ffi, lib

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

_STATE_FIELDS = (pb.BodyFields.POSITION | pb.BodyFields.ANGLE | pb.BodyFields.VELOCITY
                 | pb.BodyFields.ANGULAR_VELOCITY)
_VELOCITY_FIELDS = pb.BodyFields.VELOCITY | pb.BodyFields.ANGULAR_VELOCITY
_EMPTY = np.zeros(0, dtype=np.int64)
HASH_CELL = 1.0
"""Cell size of pymunk's spatial hash [m]."""
HASH_MIN_BODIES = 64
"""Spaces with at least this many bodies use the spatial hash instead of the tree."""
_READ_SLACK = 1024
"""Spare floats in the read buffer beyond the bodies' state."""
MAX_GROUPS = 32
"""Collision groups a Space can keep apart: pymunk's collision categories are 32 bits."""


def _group_filters(groups: IntArray | None, total: int) -> list[pymunk.ShapeFilter]:
    """The shape filter of each body of ``groups`` (checked); empty for None. A body of group
    g is in category g and touches only that category."""
    if groups is None:
        return []
    groups = np.asarray(groups)
    if (groups.shape != (total,) or groups.dtype.kind not in "iu"
            or (total and not 0 <= groups.min() <= groups.max() < MAX_GROUPS)):
        raise ValueError(f"groups must hold one collision group in [0, {MAX_GROUPS}) per body, "
                         f"shape ({total},) ints, got {groups.dtype} values of shape "
                         f"{groups.shape}")
    made = {g: pymunk.ShapeFilter(categories=1 << g, mask=1 << g)
            for g in np.unique(groups).tolist()}
    return [made[g] for g in groups.tolist()]


class PhysicsWorld:
    """A pymunk Space with ``num_cars`` car boxes, ``num_obstacles`` obstacle boxes and
    ``num_bots`` bot-car boxes.

    Args:
        num_cars: Total number of cars over all env copies (C = E * N).
        num_obstacles: Total number of obstacles over all env copies (O = E * K).
        car_size: (length, width) of every car box [m].
        car_mass: Mass of a car [kg].
        car_inertia: Yaw moment of inertia of a car [kg m^2].
        obstacle_size: (length, width) of every obstacle box [m].
        friction: Coulomb friction coefficient of contacts.
        elasticity: Restitution of contacts.
        num_bots: Total number of bot cars over all env copies (Q = E * B); they have the
            cars' box.
        groups: Collision group of every body (cars, obstacles, bots), (C + O + Q,) ints in
            [0, ``MAX_GROUPS``): bodies of different groups pass through each other (pymunk's
            collision categories); None: every body may touch every other.
    """

    def __init__(
        self,
        num_cars: int,
        num_obstacles: int,
        car_size: tuple[float, float],
        car_mass: float,
        car_inertia: float,
        obstacle_size: tuple[float, float],
        friction: float,
        elasticity: float,
        num_bots: int = 0,
        groups: IntArray | None = None,
    ) -> None:
        self.num_cars = num_cars
        self.num_obstacles = num_obstacles
        self.num_bots = num_bots
        space = pymunk.Space(threaded=False)
        space.gravity = (0.0, 0.0)
        # pymunk's defaults are tuned for pixels: allow 1 mm of overlap, not 10 cm.
        space.collision_slop = 0.001
        space.iterations = 10
        space.damping = 1.0
        # Every car moves and turns every step, which makes pymunk's default bounding-box tree
        # re-insert every shape each sub-step; for many cars a spatial hash with 1 m cells (a
        # few car lengths) is about 1.5x faster (1,024 moving cars: 180 vs 280 us per
        # sub-step). For a handful of bodies the tree is cheaper than the hash's table.
        total = num_cars + num_obstacles + num_bots
        if total >= HASH_MIN_BODIES:
            space.use_spatial_hash(HASH_CELL, 8 * total)
        self.space = space
        self._bodies: list[pymunk.Body] = []
        filters = _group_filters(groups, total)
        half_l, half_w = 0.5 * car_size[0], 0.5 * car_size[1]
        car_box = [(-half_l, -half_w), (half_l, -half_w), (half_l, half_w), (-half_l, half_w)]
        for _ in range(num_cars):
            body = pymunk.Body(car_mass, car_inertia)
            shape = pymunk.Poly(body, car_box)
            shape.friction = friction
            shape.elasticity = elasticity
            if filters:
                shape.filter = filters[len(self._bodies)]
            space.add(body, shape)
            self._bodies.append(body)
        half_l, half_w = 0.5 * obstacle_size[0], 0.5 * obstacle_size[1]
        box = [(-half_l, -half_w), (half_l, -half_w), (half_l, half_w), (-half_l, half_w)]
        # Obstacles, then bot cars: kinematic bodies whose poses the core sets every step.
        for outline in [box] * num_obstacles + [car_box] * num_bots:
            body = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
            shape = pymunk.Poly(body, outline)
            shape.friction = friction
            shape.elasticity = elasticity
            if filters:
                shape.filter = filters[len(self._bodies)]
            space.add(body, shape)
            self._bodies.append(body)
        ids = np.array([b.id for b in self._bodies], dtype=np.uint64)
        self._index_of = {int(body_id): k for k, body_id in enumerate(ids)}
        # Contacts are reported by a callback that runs only when two shapes start
        # touching, so a step without new contacts pays nothing for contact detection.
        self._begun: list[tuple[int, int]] = []
        space.on_collision(begin=self._on_begin)
        # The read buffer wraps numpy memory with room to spare, so pymunk never needs to grow
        # it: pymunk must never reallocate memory that numpy owns.
        self._read_memory = np.zeros(total * 6 + _READ_SLACK, dtype=np.float64)
        self._state = self._read_memory[: total * 6].reshape(total, 6)
        self._read_buffer = pb.Buffer()
        self._read_buffer.set_float_buf(self._read_memory)
        self._write_vel_buffer = pb.Buffer()
        self._write_state_buffer = pb.Buffer()
        self._write = np.zeros((total, 6), dtype=np.float64)
        self._write_vel = np.zeros((total, 3), dtype=np.float64)
        self._write_state_buffer.set_float_buf(self._write.reshape(-1))
        self._write_vel_buffer.set_float_buf(self._write_vel.reshape(-1))
        self._command = self._write_vel[:num_cars]
        self._bind_step()
        self._check_body_order(ids)

    def __getstate__(self) -> dict[str, object]:
        # cffi batch buffers cannot be pickled; they are rebuilt around fresh numpy arrays.
        state = self.__dict__.copy()
        for key in ("_read_buffer", "_write_vel_buffer", "_write_state_buffer", "_cp_space",
                    "_cp_calls", "_set_velocities", "_get_state"):
            del state[key]
        return state

    def __setstate__(self, state: dict[str, object]) -> None:
        self.__dict__.update(state)
        # Unpickled bodies are new pymunk objects with new ids.
        self._index_of = {body.id: k for k, body in enumerate(self._bodies)}
        self._read_memory = self._read_memory.copy()
        self._state = self._read_memory[: self._state.size].reshape(self._state.shape)
        self._write = self._write.copy()
        self._write_vel = self._write_vel.copy()
        self._read_buffer = pb.Buffer()
        self._read_buffer.set_float_buf(self._read_memory)
        self._write_state_buffer = pb.Buffer()
        self._write_state_buffer.set_float_buf(self._write.reshape(-1))
        self._write_vel_buffer = pb.Buffer()
        self._write_vel_buffer.set_float_buf(self._write_vel.reshape(-1))
        self._command = self._write_vel[: self.num_cars]
        self._bind_step()

    def _bind_step(self) -> None:
        """Build once what :meth:`step` hands chipmunk on every step.

        pymunk's ``Space.step`` and ``batch.get/set_space_bodies`` rebuild their C arguments
        and re-check pending additions on every call, which costs a 2-car env about a fifth
        of its step; :meth:`step` makes the same chipmunk calls with arguments built here.
        """
        self._cp_space = self.space._space
        self._cp_calls = (lib.cpSpaceEachBody, lib.cpSpaceStep)
        set_data = ffi.new("pmBatchedData *")
        set_data.fields = _VELOCITY_FIELDS.value
        set_data.floatArray = self._write_vel_buffer._float_arr
        set_data.intArray = self._write_vel_buffer._int_arr
        get_data = ffi.new("pmBatchedData *")
        get_data.fields = _STATE_FIELDS.value
        get_data.floatArray = self._read_buffer._float_arr
        get_data.intArray = self._read_buffer._int_arr
        self._set_velocities = (ffi.addressof(lib, "pmSpaceBodySetIteratorFuncBatched"),
                                set_data, self._write_vel_buffer._float_arr)
        self._get_state = (ffi.addressof(lib, "pmSpaceBodyGetIteratorFuncBatched"), get_data,
                           self._read_buffer._float_arr, self._read_buffer._int_arr)

    def _check_body_order(self, ids: npt.NDArray[np.uint64]) -> None:
        """Verify that pymunk iterates bodies in insertion order (the batch layout relies on it)."""
        buffer = pb.Buffer()
        pb.get_space_bodies(self.space, pb.BodyFields.BODY_ID, buffer)
        got = np.frombuffer(buffer.int_buf(), dtype=np.uint64)
        assert np.array_equal(got, ids), "pymunk body iteration order differs from insertion"

    def set_state(self, position: FloatArray, angle: FloatArray, velocity: FloatArray,
                  angular_velocity: FloatArray) -> None:
        """Teleport every body (cars, then obstacles, then bots).

        Args:
            position: Shape (C + O + Q, 2), metres.
            angle: Shape (C + O + Q,), radians.
            velocity: Shape (C + O + Q, 2), m/s.
            angular_velocity: Shape (C + O + Q,), rad/s.
        """
        write = self._write
        write[:, 0:2] = position
        write[:, 2] = angle
        write[:, 3:5] = velocity
        write[:, 5] = angular_velocity
        # Shapes of dynamic and kinematic bodies are re-indexed at the start of every
        # pymunk step, so teleported bodies need no explicit re-index.
        pb.set_space_bodies(self.space, _STATE_FIELDS, self._write_state_buffer)
        # What pymunk now holds, until the next step reads it back: a later write that keeps
        # some bodies as they are reads them here.
        self._state[...] = write

    @property
    def state(self) -> FloatArray:
        """Every body's state, (C + O + Q, 6): x, y, angle, vx, vy, omega, as pymunk holds it
        after the last :meth:`step` or :meth:`set_state` (refreshed in place by each)."""
        return self._state

    @property
    def command(self) -> FloatArray:
        """The car velocities to hold during the next step, (C, 3): vx, vy, omega (writable).

        Fill it (e.g. straight from the dynamics kernel), then call :meth:`step`.
        """
        return self._command

    @property
    def bot_command(self) -> FloatArray:
        """The bot velocities to hold during the next step, (Q, 3): vx, vy, omega (writable).

        Kinematic bodies move with these velocities whatever they touch."""
        return self._write_vel[self.num_cars + self.num_obstacles:]

    def step(self, dt: float, substeps: int) -> None:
        """Hold the car velocities in :attr:`command` (and the bots' in :attr:`bot_command`),
        run ``substeps`` pymunk steps, and read
        every body back into :attr:`state`.

        Args:
            dt: Total step length [s], split evenly over the sub-steps.
            substeps: Number of pymunk steps.
        """
        space = self.space
        sub_dt = dt / substeps
        if (space._bodies_to_check or space._add_later or space._remove_later
                or space._post_step_callbacks):
            # pymunk's own wrapper checks new bodies and runs deferred work (the first step).
            pb.set_space_bodies(space, _VELOCITY_FIELDS, self._write_vel_buffer)
            for _ in range(substeps):
                space.step(sub_dt)
            self._read_buffer.clear()
            pb.get_space_bodies(space, _STATE_FIELDS, self._read_buffer)
            return
        # The same chipmunk calls as pymunk's wrappers, with arguments built once
        # (_bind_step). Locked as pymunk locks it, so that a contact callback that added or
        # removed bodies would be deferred as usual.
        cp_space = self._cp_space
        each_body, cp_step = self._cp_calls
        set_func, set_data, write_floats = self._set_velocities
        count = write_floats.num
        write_floats.num = 0
        each_body(cp_space, set_func, set_data)
        write_floats.num = count
        space._locked = True
        try:
            for _ in range(substeps):
                cp_step(cp_space, sub_dt)
        finally:
            space._locked = False
        get_func, get_data, read_floats, read_ints = self._get_state
        read_floats.num = 0
        read_ints.num = 0
        each_body(cp_space, get_func, get_data)

    def read_cars(self) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """Read every car's position, angle, velocity and angular velocity (fresh arrays)."""
        buffer = self._read_buffer
        buffer.clear()
        pb.get_space_bodies(self.space, _STATE_FIELDS, buffer)
        data = self._state[: self.num_cars].copy()
        return data[:, 0:2], data[:, 2], data[:, 3:5], data[:, 5]

    def _on_begin(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: object) -> None:
        body_a, body_b = arbiter.bodies
        self._begun.append((self._index_of[body_a.id], self._index_of[body_b.id]))

    def pop_contacts(self) -> tuple[IntArray, IntArray]:
        """Return and forget the pairs of bodies that started touching since the last call.

        Returns:
            ``(a, b)``: body indices (cars 0..C-1, then obstacles C..C+O-1, then bots
            C+O..C+O+Q-1), shape (P,) each, in the order pymunk reported them
            (deterministic for a given Space).
        """
        if not self._begun:
            return _EMPTY, _EMPTY
        pairs = np.array(self._begun, dtype=np.int64)
        self._begun.clear()
        return pairs[:, 0], pairs[:, 1]
