#!/usr/bin/env python3
"""Writes the seed corpora of the volume and calls fuzzers (fuzz/corpus/volume,
fuzz/corpus/calls) in the input layouts documented at the top of
fuzz_volume.cpp and fuzz_calls.cpp, and small valid and refused NRRD and
MetaImage files (fuzz/corpus/nrrd, fuzz/corpus/metaimage). Deterministic; run from anywhere:

    python3 fuzz/make_seeds.py

(fuzz/corpus/nifti holds real and hand-broken NIfTI files instead.)"""
import gzip
import math
import os
import struct
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))

TYPES = {1: ('B', 1), 2: ('h', 2), 3: ('H', 2), 4: ('i', 4), 5: ('f', 4), 6: ('d', 8)}


def ball(dims, vtype, inside=1, outside=0, centre=None, r=None, order=(0, 1, 2)):
    """Voxel bytes of a binary ball, contiguous with axis order[0] fastest."""
    fmt, _ = TYPES[vtype]
    if centre is None:
        centre = [(d - 1) / 2.0 for d in dims]
    if r is None:
        r = min(dims) / 3.0
    out = bytearray()
    a0, a1, a2 = order
    for z in range(dims[a2]):
        for y in range(dims[a1]):
            for x in range(dims[a0]):
                ijk = [0, 0, 0]
                ijk[a0], ijk[a1], ijk[a2] = x, y, z
                d2 = sum((ijk[a] - centre[a]) ** 2 for a in range(3))
                out += struct.pack('<' + fmt, inside if d2 < r * r else outside)
    return bytes(out)


def volume_seed(vtype, flags, mesh, steps, dims=None, raw_dims=None, layout=0, raw_strides=None,
                raw_offset=None, spacing=(4, 4, 4), angle=0, trans=(0, 0, 0), raw_affine=None,
                rescale=None, raw_sphere=None, sphere=(128, 128, 128, 12), params=None, data=b''):
    b = bytearray([vtype, flags, mesh, steps])
    if flags & 1:
        b += struct.pack('<3q', *raw_dims)
    else:
        b += bytes([(d - 1) % 16 for d in dims])
    if flags & 2:
        b += struct.pack('<3q', *raw_strides)
    else:
        b += bytes([layout])
    if flags & 4:
        b += struct.pack('<q', raw_offset)
    if flags & 8:
        b += struct.pack('<16d', *raw_affine)
    else:
        b += bytes(spacing) + bytes([angle]) + struct.pack('<3b', *trans)
    if flags & 16:
        b += struct.pack('<2d', *rescale)
    if flags & 32:
        b += struct.pack('<4d', *raw_sphere)
    else:
        b += bytes(sphere)
    if flags & 64:
        b += bytes(params)
    return bytes(b) + data


def volume_seeds():
    s = {}
    # spacing byte s -> 0.25 + 0.25 * s mm; sphere radius byte r -> 0.25 * (1 + r) mm.
    s['u8_ball_8cube'] = volume_seed(1, 0, 6, 3, dims=(8, 8, 8), spacing=(3, 3, 3),
                                     sphere=(128, 128, 128, 5), data=ball((8, 8, 8), 1))
    # mesh byte m -> n = 2 + m % 3; steps are capped at 9 / n^2 (fuzz_volume.cpp).
    s['u8_ball_12cube_n4'] = volume_seed(1, 0, 2, 0x81, dims=(12, 12, 12), spacing=(3, 3, 3),
                                         sphere=(120, 130, 125, 9), data=ball((12, 12, 12), 1))
    s['f32_ball_flipped_padded'] = volume_seed(
        5, 0, 5, 2, dims=(6, 7, 5), layout=0x08 | 0x05, spacing=(3, 5, 7), angle=20, trans=(-3, 4, 1),
        sphere=(100, 140, 120, 10),
        data=ball((7, 7, 5), 5, inside=1.5, outside=0.0, centre=(2.5, 3, 2), r=2.2))
    s['i16_permuted'] = volume_seed(2, 0, 4, 2, dims=(6, 6, 6), layout=0x30, spacing=(3, 3, 3),
                                    sphere=(128, 128, 128, 6), data=ball((6, 6, 6), 2, inside=200, order=(2, 0, 1)))
    s['u16_rescaled'] = volume_seed(3, 16, 4, 2, dims=(6, 6, 6), spacing=(3, 3, 3), rescale=(0.5, -10.0),
                                    sphere=(128, 128, 128, 6), data=ball((6, 6, 6), 3, inside=60, outside=20))
    s['i32_raw_strides'] = volume_seed(4, 2 | 4, 4, 1, dims=(4, 4, 4), raw_strides=(4, -16, 64), raw_offset=48,
                                       spacing=(3, 3, 3), sphere=(128, 128, 128, 4), data=ball((4, 4, 4), 4))
    s['f64_raw_affine'] = volume_seed(
        6, 8, 3, 2, dims=(5, 5, 5),
        raw_affine=(0, 1.2, 0, 5, -1.1, 0, 0, 2, 0, 0, 1.3, -1, 0, 0, 0, 1),
        sphere=(128, 128, 128, 6), data=ball((5, 5, 5), 6))
    s['raw_sphere_huge'] = volume_seed(1, 32, 4, 2, dims=(6, 6, 6), spacing=(3, 3, 3),
                                       raw_sphere=(2.0, 2.0, 2.0, 1e6), data=ball((6, 6, 6), 1))
    s['params_set'] = volume_seed(1, 64, 0, 3, dims=(8, 8, 8), spacing=(3, 3, 3), sphere=(128, 128, 128, 5),
                                  params=(200, 40, 0, 60, 3, 4, 0), data=ball((8, 8, 8), 1))
    # Params block, last byte: bit0 grey-level targets, bits 1-2 partial-volume
    # steps, bits 3-4 smoothing iterations, bits 5-7 intensity_gamma.
    s['grey_level_f32'] = volume_seed(5, 64, 0, 2, dims=(10, 10, 10), spacing=(3, 3, 3),
                                      sphere=(128, 128, 128, 7), params=(128, 0, 0, 51, 0, 4, 1 | 4 | 16 | 64),
                                      data=ball((10, 10, 10), 5, inside=180.0, outside=40.0))
    s['grey_level_i16_auto_range'] = volume_seed(2, 64, 1, 1, dims=(8, 8, 8), spacing=(3, 3, 3),
                                                 sphere=(128, 128, 128, 6), params=(128, 0, 10, 51, 2, 4, 1 | 2 | 8),
                                                 data=ball((8, 8, 8), 2, inside=900, outside=100))
    s['reset_bad_after'] = volume_seed(1, 128, 4, 1, dims=(6, 6, 6), spacing=(3, 3, 3), sphere=(128, 128, 128, 5),
                                       data=ball((6, 6, 6), 1))
    s['lie_dims_overflow'] = volume_seed(1, 1 | 2, 4, 1, raw_dims=(1 << 40, 1 << 40, 1 << 40),
                                         raw_strides=(1, 1 << 40, 1 << 62), data=bytes(64))
    s['lie_strides_past_end'] = volume_seed(2, 2, 4, 1, dims=(4, 4, 4), raw_strides=(2, 8, 40), data=bytes(128))
    s['lie_negative_offset'] = volume_seed(1, 4, 4, 1, dims=(4, 4, 4), raw_offset=-1, data=bytes(64))
    s['lie_short_data'] = volume_seed(5, 0, 4, 1, dims=(4, 4, 4), data=bytes(255))
    s['lie_nan_affine'] = volume_seed(1, 8, 4, 1, dims=(2, 2, 2),
                                      raw_affine=(1, 0, 0, float('nan'), 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1),
                                      data=bytes(8))
    s['lie_zero_slope'] = volume_seed(1, 16, 4, 1, dims=(2, 2, 2), rescale=(0.0, 0.0), data=bytes(8))
    s['bad_type'] = volume_seed(7, 0, 4, 1, dims=(2, 2, 2), data=bytes(8))
    s['single_voxel'] = volume_seed(1, 0, 2, 4, dims=(1, 1, 1), spacing=(3, 3, 3), sphere=(128, 128, 128, 3),
                                    data=b'\x01')
    s['empty_data'] = volume_seed(1, 0, 2, 1, dims=(1, 1, 1))
    return s


def calls_seed(cfg, ops):
    return bytes(cfg) + b''.join(bytes(o) for o in ops)


# op helpers (object index byte follows the op byte when op < 0x80)
def set_volume(kind=0, breakage=8, obj=0, extra=()):
    return [1, obj, kind, breakage, *extra]


def init_sphere(obj=0, mode=0, dx=0, dy=0, dz=0, r=56):
    return [2, obj, mode, dx & 0xFF, dy & 0xFF, dz & 0xFF] + ([r] if not mode & 2 else [])


def step(obj=0, mode=0):
    return [3, obj, mode]


def extract(obj=0, mode=0):
    return [4, obj, mode]


def rasterize(obj=0, mode=0):
    return [5, obj, mode]


def calls_seeds():
    good_cfg = [0, 1, 6, 8, 0]  # cflags 0: objects 2, n 8, roi 2^16, exact size
    s = {}
    s['happy_path'] = calls_seed(good_cfg, [set_volume(), init_sphere(), step(), step(), extract(), rasterize(),
                                            rasterize(mode=2)])
    s['misuse_order'] = calls_seed(good_cfg, [step(), extract(), rasterize(), init_sphere(), set_volume(),
                                              step(), extract(obj=1), init_sphere(obj=2), step()])
    s['short_buffers'] = calls_seed(good_cfg, [set_volume(kind=1), init_sphere(), extract(mode=0x11),
                                               extract(mode=0x22), extract(mode=0x33), extract(mode=0x08),
                                               extract(mode=0x04), extract(mode=0x0C)])
    s['params_extreme'] = calls_seed(good_cfg, [
        [0, 0, 0xFE, 0x0F, 20, 20, 22, 23, 21, 0xFF, 20, 21, 22, 23],
        [0, 0, 0x80, 0x00, 5],  # search_step tiny (table index 5: 1e-300)
        set_volume(), init_sphere(), step(),
        [0, 0, 0x40, 0x00, 8],  # search_range 1e300
        step(),
        [0, 0, 0x00, 0x10],  # NULL params
        [0, 0, 0x00, 0x08, 7],  # struct_size 7
        step(), extract()])
    s['destroy_recreate'] = calls_seed(good_cfg, [set_volume(), init_sphere(), step(), [7, 0], step(),
                                                  set_volume(kind=2), init_sphere(obj=1), step(), extract(obj=1)])
    s['broken_volumes'] = calls_seed(good_cfg, [set_volume(breakage=b, extra=(0xFF,) * 8) for b in range(8)] +
                                     [set_volume(breakage=255), step(), init_sphere()])
    s['odd_workspace_small'] = calls_seed([0, 1, 6, 8, 0xFF], [set_volume(), init_sphere(), step()])
    s['odd_workspace_misaligned'] = calls_seed([64, 1, 6, 8, 0, 7], [set_volume(), init_sphere(), step()])
    s['odd_config'] = calls_seed([1 | 2 | 8 | 16, 0, 1, 8, 4], [set_volume(), step()])
    s['odd_config_huge'] = calls_seed([1 | 2 | 4, 200, 250] + list(struct.pack('<q', 1 << 41)), [step()])
    s['sample_and_nulls'] = calls_seed(good_cfg, [[6, 0, 20, 21, 22, 3], set_volume(), [6, 0, 2, 3, 4, 1],
                                                  [0x48, 7, 1, 2, 3, 0], [9, 0], [10, 0, 0xF7, 0xFF, 0xFF, 0xFF],
                                                  [8, 0, 100]])
    s['sphere_extremes'] = calls_seed(good_cfg, [set_volume(), init_sphere(mode=1 | 2, dx=20, dy=21, dz=22, r=0),
                                                 [2, 0, 3, 0, 0, 0, 9], [2, 0, 3, 1, 1, 1, 8], [2, 0, 4, 0, 0, 0, 10],
                                                 [2, 5, 0, 0, 0, 0, 10], [0x86, 0xF0, 0, 0, 0, 0, 10], step(),
                                                 extract()])
    s['many_objects'] = calls_seed([1, 4, 6, 8, 0], [set_volume(kind=1)] +
                                   [init_sphere(obj=o, dx=4 * o, r=40 + 4 * o) for o in range(4)] +
                                   [step(), step(), extract(obj=3), rasterize(obj=2)])
    # Two objects at n = 2 whose bounding regions must be marched on cells:
    # roi byte 7 * 12 + 8 (crops 2^16, regions 256 voxels, 0.6.0).
    s['regions_on_cells'] = calls_seed([0, 1, 0, 7 * 12 + 8, 0],
                                       [set_volume(), init_sphere(dx=-64, r=16), init_sphere(obj=1, dx=64, r=16),
                                        step(), rasterize(mode=4), rasterize(obj=1, mode=4 | 2)])
    return s


# ---- NRRD and MetaImage (fuzz_nrrd, fuzz_metaimage): text headers + data ----------

def ramp(n, fmt):
    return b''.join(struct.pack(fmt, (i * 7) % 100) for i in range(n))


def nrrd_seeds():
    s = {}
    s['u8_raw_spacings'] = (b'NRRD0004\ntype: uchar\ndimension: 3\nsizes: 3 4 2\nspacings: 1.5 1 2\n'
                            b'encoding: raw\n\n' + ramp(24, '<B'))
    s['i16_lps_directions'] = (b'NRRD0005\n# comment\ntype: short\ndimension: 3\nspace: left-posterior-superior\n'
                               b'sizes: 2 3 2\nspace directions: (0.9,0,0) (0,1.1,0.1) (0,0,2.5)\n'
                               b'space origin: (-10,4,1)\nkinds: domain domain domain\nendian: little\n'
                               b'encoding: raw\n\n' + ramp(12, '<h'))
    s['f32_big_endian_ras'] = (b'NRRD0004\ntype: float\ndimension: 3\nspace: RAS\nsizes: 2 2 2\n'
                               b'space directions: (1,0,0) (0,1,0) (0,0,1)\nspace units: "mm" "mm" "mm"\n'
                               b'endian: big\nencoding: raw\n\n' + ramp(8, '>f'))
    s['f64_gzip'] = (b'NRRD0004\ntype: double\ndimension: 3\nsizes: 2 2 3\nendian: little\nencoding: gzip\n'
                     b'key:=value\n\n' + gzip.compress(ramp(12, '<d'), mtime=0))
    s['u16_byteskip'] = (b'NRRD0004\ntype: ushort\ndimension: 3\nsizes: 2 2 2\nendian: little\n'
                         b'byte skip: -1\nencoding: raw\n\n' + b'junk' + ramp(8, '<H'))
    s['refused_detached'] = b'NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\ndata file: x.raw\nencoding: raw\n\n'
    return s


def metaimage_seeds():
    s = {}
    s['uchar_local'] = (b'ObjectType = Image\nNDims = 3\nDimSize = 3 4 2\nElementSpacing = 1.5 1 2\n'
                        b'ElementType = MET_UCHAR\nElementDataFile = LOCAL\n' + ramp(24, '<B'))
    s['short_transform'] = (b'ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n'
                            b'TransformMatrix = 0 1 0 -1 0 0 0 0 1\nOffset = -10 4 1\nElementSpacing = 0.9 1.1 2.5\n'
                            b'DimSize = 2 3 2\nElementType = MET_SHORT\nElementDataFile = LOCAL\n' + ramp(12, '<h'))
    s['float_msb'] = (b'ObjectType = Image\nNDims = 3\nDimSize = 2 2 2\nElementByteOrderMSB = True\n'
                      b'ElementType = MET_FLOAT\nElementDataFile = LOCAL\n' + ramp(8, '>f'))
    comp = zlib.compress(ramp(12, '<d'))
    s['double_compressed'] = (b'ObjectType = Image\nNDims = 3\nDimSize = 2 2 3\nCompressedData = True\n'
                              b'CompressedDataSize = ' + str(len(comp)).encode() + b'\nElementType = MET_DOUBLE\n'
                              b'ElementDataFile = LOCAL\n' + comp)
    s['ulong_long'] = (b'ObjectType = Image\nNDims = 3\nDimSize = 2 1 2\nElementType = MET_ULONG_LONG\n'
                       b'Comment = seed\nElementDataFile = LOCAL\n' + ramp(4, '<Q'))
    s['refused_ascii'] = (b'ObjectType = Image\nNDims = 3\nDimSize = 1 1 1\nBinaryData = False\n'
                          b'ElementType = MET_UCHAR\nElementDataFile = LOCAL\n1\n')
    return s


def write(dirname, seeds):
    d = os.path.join(HERE, 'corpus', dirname)
    os.makedirs(d, exist_ok=True)
    for name, data in seeds.items():
        with open(os.path.join(d, name), 'wb') as f:
            f.write(data)
    print('%s: %d seeds' % (d, len(seeds)))


if __name__ == '__main__':
    write('volume', volume_seeds())
    write('calls', calls_seeds())
    write('nrrd', nrrd_seeds())
    write('metaimage', metaimage_seeds())
