#!/usr/bin/env python3
"""Writes room_01.scene .. room_10.scene: seeded rooms for robot_sim (issue 24, object finding and the closed loop).

    python3 drivers/robot_sim/scenes/rooms/make_rooms.py            # rewrites the 10 files next to this script
    python3 drivers/robot_sim/scenes/rooms/make_rooms.py --check    # exits 1 if a checked-in file differs

Standard library only, deterministic (random.Random(seed) per room); the output is checked in, so nothing at build or
test time runs Python. Lengths in mm, angles in degrees, world z up, floor z = 0 (the scene format of README.md).

Every room: a rectangular room of 5-7 m per side centred at the origin, walls = textured boxes 100 mm thick and
800-1200 mm high; a textured floor; 5 or 6 objects:
  target      exactly one, target=true, textured, every extent 80-300 mm, on the floor (sphere, box, cylinder or
              ../blob.ply scaled; over the 10 rooms each shape at least twice)
  table       a table-sized textured box, 700-1000 x 500-700 x 700 mm
  pillar      a textured cylinder, radius 200-300 mm, as high as the walls
  rug         a textured box 5 mm high, ~1000 x 700 mm (drivable: lower than 20 mm)
  plain_*     a small object without texture (texture=solid), largest extent 100-250 mm
  crate       (rooms 2, 4, 6, 8, 10) a textured box 350-500 mm: too big to be the target
and a `robot start=x,y,yaw pan=0 tilt=25` line.

Constraints, enforced here by rejection sampling and checked again by drivers/robot_sim/rooms_test.cpp (which uses the
simulator's own footprint geometry: box = yawed rectangle, cylinder/sphere = circle, mesh = convex hull):
  * the start is >= 1500 mm from the target centre (here >= 1800) and does not face it: the bearing of the target
    from the start heading is >= 70 deg (here >= 90), far outside the camera's +-22 deg at pan 0;
  * the start footprint (radius 200 mm) is free (here >= 100 mm clearance from everything), and the start heading
    meets a wall within 2000 mm, so the first image (tilt 25 deg) shows floor and wall;
  * a free ring: every point within 1100 mm of the target centre is >= 300 mm (footprint + 100) from every other
    non-drivable object and from the walls, i.e. their footprints are >= 1400 mm (here >= 1450) from the centre;
  * objects do not overlap (here: non-drivable objects >= 450 mm apart and from the walls, so the base can pass;
    the rug >= 100 mm from everything);
  * the target is not hidden (behind the table or anything else) from everywhere: from >= 60 % of the free floor
    (a 250 mm grid of base positions whose footprint is free) the straight floor line to the target centre crosses
    no other non-drivable footprint (the test asks >= 50 %).
"""
import math
import os
import random
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
FOOTPRINT = 200.0  # mm, robot_sim's default base radius
TARGET_SHAPES = ["sphere", "box", "cylinder", "mesh", "box", "sphere", "mesh", "cylinder", "sphere", "box"]


# ---------------------------------------------------------------------------------------------------------- geometry
# A footprint is ("circle", (cx, cy), r) or ("poly", [(x, y), ...] counter-clockwise, convex).

def cross(o, a, b):
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def seg_dist(p, a, b):
    ab = (b[0] - a[0], b[1] - a[1])
    l2 = ab[0] ** 2 + ab[1] ** 2
    t = 0.0 if l2 == 0 else max(0.0, min(1.0, ((p[0] - a[0]) * ab[0] + (p[1] - a[1]) * ab[1]) / l2))
    return math.hypot(a[0] + t * ab[0] - p[0], a[1] + t * ab[1] - p[1])


def signed_distance(shape, p):
    if shape[0] == "circle":
        return math.hypot(p[0] - shape[1][0], p[1] - shape[1][1]) - shape[2]
    poly = shape[1]
    n = len(poly)
    inside = all(cross(poly[i], poly[(i + 1) % n], p) >= 0 for i in range(n))
    d = min(seg_dist(p, poly[i], poly[(i + 1) % n]) for i in range(n))
    return -d if inside else d


def as_polygon(shape, segments=64):
    if shape[0] == "poly":
        return shape[1]
    (cx, cy), r = shape[1], shape[2] / math.cos(math.pi / segments)  # circumscribed
    return [(cx + r * math.cos(2 * math.pi * k / segments), cy + r * math.sin(2 * math.pi * k / segments))
            for k in range(segments)]


def polygons_overlap(a, b):
    """Separating axis test for convex polygons."""
    for poly in (a, b):
        for i in range(len(poly)):
            p, q = poly[i], poly[(i + 1) % len(poly)]
            axis = (q[1] - p[1], p[0] - q[0])
            pa = [axis[0] * v[0] + axis[1] * v[1] for v in a]
            pb = [axis[0] * v[0] + axis[1] * v[1] for v in b]
            if max(pa) < min(pb) or max(pb) < min(pa):
                return False
    return True


def shape_distance(a, b):
    """Distance between two footprints (< 0 when they overlap)."""
    if a[0] == "circle" and b[0] == "circle":
        return math.hypot(a[1][0] - b[1][0], a[1][1] - b[1][1]) - a[2] - b[2]
    if a[0] == "circle":
        return signed_distance(b, a[1]) - a[2]
    if b[0] == "circle":
        return signed_distance(a, b[1]) - b[2]
    if polygons_overlap(a[1], b[1]):
        return -1.0
    return min(min(signed_distance(b, v) for v in a[1]), min(signed_distance(a, v) for v in b[1]))


def segment_hits(shape, a, b):
    if shape[0] == "circle":
        return seg_dist(shape[1], a, b) <= shape[2]
    if signed_distance(shape, a) <= 0 or signed_distance(shape, b) <= 0:
        return True
    poly = shape[1]
    for i in range(len(poly)):
        c, d = poly[i], poly[(i + 1) % len(poly)]
        if cross(a, b, c) * cross(a, b, d) < 0 and cross(c, d, a) * cross(c, d, b) < 0:
            return True
    return False


def rect(cx, cy, sx, sy, yaw_deg):
    c, s = math.cos(math.radians(yaw_deg)), math.sin(math.radians(yaw_deg))
    return ("poly", [(cx + c * x - s * y, cy + s * x + c * y)
                     for x, y in ((-sx / 2, -sy / 2), (sx / 2, -sy / 2), (sx / 2, sy / 2), (-sx / 2, sy / 2))])


def convex_hull(points):
    pts = sorted(set(points))
    lower, upper = [], []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return lower[:-1] + upper[:-1]


def read_blob():
    with open(os.path.join(HERE, "..", "blob.ply")) as f:
        lines = f.read().split("\n")
    count = int(next(l for l in lines if l.startswith("element vertex")).split()[2])
    start = lines.index("end_header") + 1
    return [tuple(float(v) for v in lines[start + i].split()[:3]) for i in range(count)]


BLOB = read_blob()


def blob_placement(scale, yaw_deg, cx, cy):
    """Footprint hull and z extent of blob.ply placed as robot_sim places a mesh (scale, yaw, bounding-box centre at
    (cx, cy), lowered onto the floor)."""
    c, s = math.cos(math.radians(yaw_deg)), math.sin(math.radians(yaw_deg))
    rotated = [(c * scale * x - s * scale * y, s * scale * x + c * scale * y) for x, y, _ in BLOB]
    mx = (min(p[0] for p in rotated) + max(p[0] for p in rotated)) / 2
    my = (min(p[1] for p in rotated) + max(p[1] for p in rotated)) / 2
    return ("poly", convex_hull([(p[0] - mx + cx, p[1] - my + cy) for p in rotated]))


def blob_extents():
    return [max(p[k] for p in BLOB) - min(p[k] for p in BLOB) for k in range(3)]


# -------------------------------------------------------------------------------------------------------------- rooms

def r1(v):
    """Angles: 0.1 deg."""
    return round(v, 1)


def mm(v):
    """Positions: whole mm."""
    return float(round(v))


def mm2(v):
    """Sizes: even mm, so that half sizes and centres are whole mm too."""
    return float(2 * round(v / 2))


def fmt(v):
    text = ("%.1f" % v).rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def make_target(rng, shape, room):
    """Returns (description without position, footprint at (cx, cy), extents, centre z)."""
    yaw = r1(rng.uniform(0, 180))
    seed = 1000 * room + 7
    texel = rng.choice([0.4, 0.5, 0.6])
    tex = "seed=%d texel_mm=%s" % (seed, fmt(texel))
    if shape == "sphere":
        r = mm(rng.uniform(45, 145))
        return ("sphere name=target_sphere radius=%s %s target=true" % (fmt(r), tex),
                lambda x, y: ("circle", (x, y), r), (2 * r, 2 * r, 2 * r), r)
    if shape == "box":
        sx, sy, sz = mm2(rng.uniform(90, 290)), mm2(rng.uniform(90, 290)), mm2(rng.uniform(80, 280))
        return ("box name=target_box size=%s,%s,%s yaw=%s %s target=true" % (fmt(sx), fmt(sy), fmt(sz), fmt(yaw), tex),
                lambda x, y: rect(x, y, sx, sy, yaw), (sx, sy, sz), sz / 2)
    if shape == "cylinder":
        r, h = mm(rng.uniform(45, 140)), mm2(rng.uniform(90, 290))
        return ("cylinder name=target_cylinder radius=%s height=%s yaw=%s %s target=true" % (fmt(r), fmt(h), fmt(yaw),
                                                                                             tex),
                lambda x, y: ("circle", (x, y), r), (2 * r, 2 * r, h), h / 2)
    ext = blob_extents()
    scale = round(rng.uniform(150, 290) / max(ext), 3)
    yaw = r1(rng.uniform(0, 360))
    sizes = tuple(scale * e for e in ext)
    return ("mesh name=target_blob file=../blob.ply scale=%s on_floor=true yaw=%s %s target=true" % (
        ("%.3f" % scale).rstrip("0"), fmt(yaw), tex), lambda x, y: blob_placement(scale, yaw, x, y), sizes, 0.0)


def place(rng, room_half, footprint_at, others, wall_shapes, gap, target_xy=None, ring=None, tries=4000):
    """Samples a position whose footprint keeps `gap` from the walls and from `others`, and >= ring from target_xy."""
    for _ in range(tries):
        x = mm(rng.uniform(-room_half[0], room_half[0]))
        y = mm(rng.uniform(-room_half[1], room_half[1]))
        shape = footprint_at(x, y)
        if any(shape_distance(shape, w) < gap for w in wall_shapes):
            continue
        if any(shape_distance(shape, o) < gap for o in others):
            continue
        if ring is not None and signed_distance(shape, target_xy) < ring:
            continue
        return x, y, shape
    return None


def visible_fraction(room_half, obstacles, target_shape, target_xy):
    free = seen = 0
    nx, ny = int(2 * room_half[0] // 250), int(2 * room_half[1] // 250)
    for i in range(nx + 1):
        for j in range(ny + 1):
            p = (-room_half[0] + 250 * i, -room_half[1] + 250 * j)
            if min(signed_distance(o, p) for o in obstacles + [target_shape]) < FOOTPRINT:
                continue
            free += 1
            if not any(segment_hits(o, p, target_xy) for o in obstacles):
                seen += 1
    return seen / max(free, 1)


def wall_ahead(room_half, x, y, yaw_deg):
    """Distance from (x, y) along the heading to the nearest inner wall face."""
    c, s = math.cos(math.radians(yaw_deg)), math.sin(math.radians(yaw_deg))
    best = float("inf")
    if c > 1e-9:
        best = min(best, (room_half[0] - x) / c)
    if c < -1e-9:
        best = min(best, (-room_half[0] - x) / c)
    if s > 1e-9:
        best = min(best, (room_half[1] - y) / s)
    if s < -1e-9:
        best = min(best, (-room_half[1] - y) / s)
    return best


def make_room(room):
    rng = random.Random(24000 + room)
    while True:
        result = try_room(rng, room)
        if result is not None:
            return result


def try_room(rng, room):
    width, depth = mm2(rng.uniform(5000, 7000)), mm2(rng.uniform(5000, 7000))
    wall_h = mm2(rng.uniform(800, 1200))
    half = (width / 2, depth / 2)
    t = 100.0
    # north/south walls span the corners; east/west walls fit between them (they touch, they do not overlap)
    walls = [("wall_north", 0.0, half[1] + t / 2, width + 2 * t, t),
             ("wall_south", 0.0, -half[1] - t / 2, width + 2 * t, t),
             ("wall_east", half[0] + t / 2, 0.0, t, depth), ("wall_west", -half[0] - t / 2, 0.0, t, depth)]
    wall_shapes = [rect(x, y, sx, sy, 0) for _, x, y, sx, sy in walls]
    lines = []
    for k, (name, x, y, sx, sy) in enumerate(walls):
        lines.append("box name=%s center=%s,%s,%s size=%s,%s,%s seed=%d texel_mm=2.5 saturation=0.35 contrast=0.7" % (
            name, fmt(x), fmt(y), fmt(wall_h / 2), fmt(sx), fmt(sy), fmt(wall_h), 1000 * room + 11 + k))

    # target: >= 1450 mm from the walls' inner faces (ring 1400 + margin)
    shape = TARGET_SHAPES[room - 1]
    target_text, target_at, target_size, target_z = make_target(rng, shape, room)
    tx = mm(rng.uniform(-(half[0] - 1450), half[0] - 1450))
    ty = mm(rng.uniform(-(half[1] - 1450), half[1] - 1450))
    target_shape = target_at(tx, ty)
    target_xy = (tx, ty)
    if any(shape_distance(("circle", target_xy, 0.0), w) < 1450 for w in wall_shapes):
        return None
    name_pos = target_text.index(" ", target_text.index("name="))
    lines.append(target_text[:name_pos] + " center=%s,%s,%s" % (fmt(tx), fmt(ty), fmt(target_z)) +
                 target_text[name_pos:])

    obstacles = []  # non-drivable footprints other than the target (and the walls)
    summary = {"target": shape}

    def add(footprint_at, text_at, label):
        placed = place(rng, half, footprint_at, obstacles + [target_shape], wall_shapes, 450.0, target_xy, 1450.0)
        if placed is None:
            return False
        x, y, fp = placed
        obstacles.append(fp)
        lines.append(text_at(x, y))
        summary[label] = (x, y)
        return True

    # table
    sx, sy, yaw = mm2(rng.uniform(700, 1000)), mm2(rng.uniform(500, 700)), r1(rng.uniform(0, 180))
    if not add(lambda x, y: rect(x, y, sx, sy, yaw),
               lambda x, y: "box name=table center=%s,%s,350 size=%s,%s,700 yaw=%s seed=%d texel_mm=1" % (
                   fmt(x), fmt(y), fmt(sx), fmt(sy), fmt(yaw), 1000 * room + 21), "table"):
        return None
    # pillar
    pr = mm(rng.uniform(200, 300))
    if not add(lambda x, y: ("circle", (x, y), pr),
               lambda x, y: "cylinder name=pillar center=%s,%s,%s radius=%s height=%s seed=%d texel_mm=1" % (
                   fmt(x), fmt(y), fmt(wall_h / 2), fmt(pr), fmt(wall_h), 1000 * room + 22), "pillar"):
        return None
    # small object without texture
    plain = rng.choice(["box", "cylinder", "sphere"])
    colour = "%d,%d,%d" % (rng.randint(60, 200), rng.randint(60, 200), rng.randint(60, 200))
    if plain == "box":
        a, b, c = mm2(rng.uniform(100, 250)), mm2(rng.uniform(100, 250)), mm2(rng.uniform(100, 250))
        pyaw = r1(rng.uniform(0, 180))
        ok = add(lambda x, y: rect(x, y, a, b, pyaw),
                 lambda x, y: "box name=plain_box center=%s,%s,%s size=%s,%s,%s yaw=%s texture=solid color=%s" % (
                     fmt(x), fmt(y), fmt(c / 2), fmt(a), fmt(b), fmt(c), fmt(pyaw), colour), "plain")
    elif plain == "cylinder":
        a, c = mm(rng.uniform(50, 125)), mm2(rng.uniform(100, 250))
        ok = add(lambda x, y: ("circle", (x, y), a),
                 lambda x, y: "cylinder name=plain_cylinder center=%s,%s,%s radius=%s height=%s texture=solid "
                              "color=%s" % (fmt(x), fmt(y), fmt(c / 2), fmt(a), fmt(c), colour), "plain")
    else:
        a = mm(rng.uniform(50, 125))
        ok = add(lambda x, y: ("circle", (x, y), a),
                 lambda x, y: "sphere name=plain_sphere center=%s,%s,%s radius=%s texture=solid color=%s" % (
                     fmt(x), fmt(y), fmt(a), fmt(a), colour), "plain")
    if not ok:
        return None
    # crate in even rooms
    if room % 2 == 0:
        cs, cyaw = mm2(rng.uniform(350, 500)), r1(rng.uniform(0, 90))
        if not add(lambda x, y: rect(x, y, cs, cs, cyaw),
                   lambda x, y: "box name=crate center=%s,%s,%s size=%s,%s,%s yaw=%s seed=%d texel_mm=0.8" % (
                       fmt(x), fmt(y), fmt(cs / 2), fmt(cs), fmt(cs), fmt(cs), fmt(cyaw), 1000 * room + 23), "crate"):
            return None
    # rug: drivable, >= 100 mm from everything (it may lie in the target's ring)
    rx, ry, ryaw = mm2(rng.uniform(900, 1200)), mm2(rng.uniform(600, 800)), r1(rng.uniform(0, 180))
    placed = place(rng, half, lambda x, y: rect(x, y, rx, ry, ryaw), obstacles + [target_shape], wall_shapes, 100.0)
    if placed is None:
        return None
    lines.append("box name=rug center=%s,%s,2.5 size=%s,%s,5 yaw=%s seed=%d texel_mm=1 saturation=0.9" % (
        fmt(placed[0]), fmt(placed[1]), fmt(rx), fmt(ry), fmt(ryaw), 1000 * room + 24))

    # start: free (>= 100 mm clearance), >= 1800 mm from the target, target bearing >= 90 deg, a wall ahead <= 2000
    everything = obstacles + [target_shape] + wall_shapes
    for _ in range(4000):
        sx0, sy0 = mm(rng.uniform(-half[0], half[0])), mm(rng.uniform(-half[1], half[1]))
        clearance = min(signed_distance(o, (sx0, sy0)) for o in everything) - FOOTPRINT
        distance = math.hypot(tx - sx0, ty - sy0)
        if clearance < 100 or distance < 1800:
            continue
        heading = r1(rng.uniform(-180, 180))
        bearing = math.degrees(math.atan2(ty - sy0, tx - sx0)) - heading
        bearing = abs((bearing + 180) % 360 - 180)
        if bearing < 90 or wall_ahead(half, sx0, sy0, heading) > 2000:
            continue
        break
    else:
        return None
    visible = visible_fraction(half, obstacles + wall_shapes, target_shape, target_xy)
    if visible < 0.6:
        return None
    ring = min(signed_distance(o, target_xy) for o in obstacles + wall_shapes)
    header = [
        "# objscan robot_sim room %02d: generated by drivers/robot_sim/scenes/rooms/make_rooms.py (rerun it, do not "
        "edit)." % room,
        "# %s x %s mm, walls %s mm high; target: %s, %s mm; the rug is 5 mm high (drivable)." % (
            fmt(width), fmt(depth), fmt(wall_h), shape, " x ".join(fmt(round(v)) for v in target_size)),
        "# start: %d mm from the target, target bearing %d deg from the heading, clearance %d mm (footprint 200)." % (
            round(distance), round(bearing), round(clearance)),
        "# nearest other object or wall: %d mm from the target centre (>= 1100 + 300)." % round(ring),
        "# the target is in line of sight from %d %% of the free floor." % round(100 * visible),
        "scene seed=%d background=200,195,190" % room,
        "light direction=0.4,0.25,1 ambient=0.45 diffuse=0.6",
        "floor size=10000 texture=leaves seed=%d texel_mm=1.5 saturation=0.3 contrast=0.6" % (1000 * room + 1),
        "robot start=%s,%s,%s pan=0 tilt=25" % (fmt(sx0), fmt(sy0), fmt(heading)),
    ]
    return "\n".join(header + lines) + "\n"


def main():
    check = "--check" in sys.argv[1:]
    differ = 0
    for room in range(1, 11):
        text = make_room(room)
        path = os.path.join(HERE, "room_%02d.scene" % room)
        if check:
            old = open(path).read() if os.path.exists(path) else None
            if old != text:
                print("differs: %s" % path)
                differ += 1
        else:
            with open(path, "w") as f:
                f.write(text)
            print("wrote %s" % path)
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
