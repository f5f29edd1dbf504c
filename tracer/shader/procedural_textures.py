"""The shader program's procedural texture family (opcodes 300-399): Checker, Brick, Gradient,
Noise, Voronoi, Wave, Magic, White Noise and Gabor, each computed by the formulas of noise.py,
voronoi.py, patterns.py, gabor.py and hashes.py (which follow Cycles 5.0's kernel/svm files).

A row is [opcode, slot1, ..., slot7] (SPECS gives each opcode's slots). Nodes with more float
inputs than a row has slots read them from parameter blocks: PARAMS gathers three float
registers into a 3-wide block first (Cycles packs them into extra node rows the same way).
Enum properties are literal ints in Cycles' order (the constants of the formula modules), with
their bounds in SPECS' third entry (program.check_program holds rows to them); Noise and
Voronoi have more of them than free slots and carry one `settings` int whose decimal digits are
the enums (settings(3, 1, 1) = 311: see `settings` and `setting`). A node whose float outputs
are computed in a block (Noise's Fac, Brick's mortar, Voronoi's Distance, W and Radius) hands
them out through COMPONENT rows.
"""
from __future__ import annotations

from ..jit import jit
from .gabor import gabor_texture
from .noise import noise_texture
from .patterns import brick, checker, gradient, magic, wave, white_noise
from .voronoi import voronoi_texture

PARAMS = 300
CHECKER = 301
BRICK = 302
BRICK_COLOR = 303
GRADIENT = 304
GREY = 305
NOISE = 306
VORONOI = 307
VORONOI_POSITION = 308
WAVE = 309
MAGIC = 310
WHITE_NOISE = 311
COMPONENT = 312
GABOR = 313

SPECS = {
    PARAMS: ("Texture parameters: three floats gathered into a block", "vfff---"),
    CHECKER: ("Checker Texture: Color and Fac (vector, color1, color2, scale)", "vvvfvf-"),
    BRICK: ("Brick Texture: (tint, mortar) of the point (vector, [scale, mortar size, mortar "
            "smooth], [bias, brick width, row height], [offset, squash, -]; offset and squash "
            "frequencies)", "vvvvvii"),
    BRICK_COLOR: ("Brick Texture: Color from (tint, mortar), color1, color2 and mortar colour",
                  "vvvvv--"),
    GRADIENT: ("Gradient Texture: Fac (vector; gradient type)", "vfi----", {3: 7}),
    GREY: ("Grey: a float as a grey colour (a texture's Color output that is its Fac)", "fv-----"),
    NOISE: ("Noise Texture: (Fac, Color) as a colour whose red is Fac (vector, [W, scale, "
            "detail], [roughness, lacunarity, distortion], [offset, gain, -]; settings "
            "dimensions-type-normalize, colour wanted)", "vvvvvii", {6: 500, 7: 2}),
    VORONOI: ("Voronoi Texture: (Distance, W, Radius) and Color (vector, [W, scale, detail], "
              "[roughness, lacunarity, smoothness], [exponent, randomness, -]; settings "
              "dimensions-feature-metric-normalize)", "vvvvvvi", {7: 5000}),
    VORONOI_POSITION: ("Voronoi Texture: Position and W (inputs and settings as VORONOI)",
                       "vvvvvfi", {7: 5000}),
    WAVE: ("Wave Texture: Fac (vector, [scale, distortion, detail], [detail scale, detail "
           "roughness, phase offset]; wave type, direction, profile)", "vvvfiii",
           {5: 2, 6: 4, 7: 3}),
    MAGIC: ("Magic Texture: Color and Fac (vector, scale, distortion; depth)", "vffvfi-",
            {6: 11}),
    WHITE_NOISE: ("White Noise Texture: Value and Color (vector, W; dimensions)", "vffvi--",
                  {5: 5}),
    COMPONENT: ("Component: one register of a 3-wide block as a float (a texture's float "
                "output computed in a block)", "vfi----", {3: 3}),
    GABOR: ("Gabor Texture: (Value, Phase, Intensity) (vector, [scale, frequency, anisotropy], "
            "orientation 2D, orientation 3D; type)", "vvfvvi-", {6: 2}),
}


def settings(*digits):
    """The settings int whose decimal digits are the given enums (each 0-9), first digit
    first."""
    value = 0
    for d in digits:
        if not 0 <= int(d) <= 9:
            raise ValueError(f"setting {d} is not one decimal digit")
        value = value * 10 + int(d)
    return value


@jit
def setting(value, index, count):
    """Digit `index` (0 is the first) of a settings int of `count` digits."""
    return (value // 10 ** (count - 1 - index)) % 10


@jit
def _load3(regs, r):
    return regs[r], regs[r + 1], regs[r + 2]


@jit
def _store3(regs, r, v):
    regs[r] = v[0]
    regs[r + 1] = v[1]
    regs[r + 2] = v[2]


@jit
def execute(ins, regs, data):
    """Run one row of the procedural texture family."""
    op = ins[0]
    if op == PARAMS:
        regs[ins[1]] = regs[ins[2]]
        regs[ins[1] + 1] = regs[ins[3]]
        regs[ins[1] + 2] = regs[ins[4]]
    elif op == CHECKER:
        x, y, z = _load3(regs, ins[1])
        s = regs[ins[4]]
        f = checker(x * s, y * s, z * s)
        _store3(regs, ins[5], _load3(regs, ins[2] if f == 1.0 else ins[3]))
        regs[ins[6]] = f
    elif op == BRICK:
        x, y, z = _load3(regs, ins[1])
        scale, mortar_size, mortar_smooth = _load3(regs, ins[2])
        bias, brick_width, row_height = _load3(regs, ins[3])
        offset_amount, squash_amount, _ = _load3(regs, ins[4])
        tint, mortar = brick(x * scale, y * scale, mortar_size, mortar_smooth, bias,
                             brick_width, row_height, offset_amount, ins[6], squash_amount,
                             ins[7])
        _store3(regs, ins[5], (tint, mortar, 0.0))
    elif op == BRICK_COLOR:
        # Cycles' svm_node_tex_brick: color1 tinted towards color2, except in full mortar
        tint, mortar, _ = _load3(regs, ins[1])
        c1 = _load3(regs, ins[2])
        c2 = _load3(regs, ins[3])
        m = _load3(regs, ins[4])
        if mortar != 1.0:
            c1 = ((1.0 - tint) * c1[0] + tint * c2[0], (1.0 - tint) * c1[1] + tint * c2[1],
                  (1.0 - tint) * c1[2] + tint * c2[2])
        _store3(regs, ins[5], (c1[0] * (1.0 - mortar) + m[0] * mortar,
                               c1[1] * (1.0 - mortar) + m[1] * mortar,
                               c1[2] * (1.0 - mortar) + m[2] * mortar))
    elif op == GRADIENT:
        x, y, z = _load3(regs, ins[1])
        regs[ins[2]] = gradient(ins[3], x, y, z)
    elif op == GREY:
        f = regs[ins[1]]
        _store3(regs, ins[2], (f, f, f))
    elif op == NOISE:
        x, y, z = _load3(regs, ins[1])
        w, scale, detail = _load3(regs, ins[2])
        roughness, lacunarity, distortion = _load3(regs, ins[3])
        offset, gain, _ = _load3(regs, ins[4])
        dims, kind, normalize = setting(ins[6], 0, 3), setting(ins[6], 1, 3), setting(ins[6], 2, 3)
        _, color = noise_texture(dims, x, y, z, w, scale, detail, roughness, lacunarity, offset,
                                 gain, distortion, kind, normalize != 0, ins[7] != 0)
        _store3(regs, ins[5], color)
    elif op == VORONOI or op == VORONOI_POSITION:
        x, y, z = _load3(regs, ins[1])
        w, scale, detail = _load3(regs, ins[2])
        roughness, lacunarity, smoothness = _load3(regs, ins[3])
        exponent, randomness, _ = _load3(regs, ins[4])
        s = ins[7]
        distance, color, position, w_out, radius = voronoi_texture(
            setting(s, 0, 4), setting(s, 1, 4), setting(s, 2, 4), x, y, z, w, scale, detail,
            roughness, lacunarity, smoothness, exponent, randomness, setting(s, 3, 4) != 0)
        if op == VORONOI:
            _store3(regs, ins[5], (distance, w_out, radius))
            _store3(regs, ins[6], color)
        else:
            _store3(regs, ins[5], position)
            regs[ins[6]] = w_out
    elif op == WAVE:
        x, y, z = _load3(regs, ins[1])
        scale, distortion, detail = _load3(regs, ins[2])
        detail_scale, detail_roughness, phase = _load3(regs, ins[3])
        regs[ins[4]] = wave(ins[5], ins[6], ins[7], x * scale, y * scale, z * scale, distortion,
                            detail, detail_scale, detail_roughness, phase)
    elif op == MAGIC:
        x, y, z = _load3(regs, ins[1])
        color = magic(x, y, z, regs[ins[2]], ins[6], regs[ins[3]])
        _store3(regs, ins[4], color)
        regs[ins[5]] = (color[0] + color[1] + color[2]) / 3.0
    elif op == GABOR:
        x, y, z = _load3(regs, ins[1])
        scale, frequency, anisotropy = _load3(regs, ins[2])
        ox, oy, oz = _load3(regs, ins[4])
        _store3(regs, ins[5], gabor_texture(ins[6], x, y, z, scale, frequency, anisotropy,
                                            regs[ins[3]], ox, oy, oz))
    elif op == COMPONENT:
        regs[ins[2]] = regs[ins[1] + ins[3]]
    elif op == WHITE_NOISE:
        x, y, z = _load3(regs, ins[1])
        value, color = white_noise(ins[5], x, y, z, regs[ins[2]])
        regs[ins[3]] = value
        _store3(regs, ins[4], color)
