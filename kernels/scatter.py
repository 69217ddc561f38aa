"""Scatter updates of device arrays: ``dest[index[k]] = values[k]``, one thread per entry.

Used to mirror a topology edit on the device at a cost proportional to the edit.
"""

import warp as wp

wp.set_module_options({"enable_backward": False})


@wp.kernel
def scatter_vec3(dest: wp.array(dtype=wp.vec3), index: wp.array(dtype=wp.int32),
                 values: wp.array(dtype=wp.vec3)):
    k = wp.tid()
    dest[index[k]] = values[k]


@wp.kernel
def scatter_float32(dest: wp.array(dtype=wp.float32), index: wp.array(dtype=wp.int32),
                    values: wp.array(dtype=wp.float32)):
    k = wp.tid()
    dest[index[k]] = values[k]


@wp.kernel
def scatter_int32(dest: wp.array(dtype=wp.int32), index: wp.array(dtype=wp.int32),
                  values: wp.array(dtype=wp.int32)):
    k = wp.tid()
    dest[index[k]] = values[k]
