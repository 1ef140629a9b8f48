// The light as back-projection sees it (Guennebaud et al. 2006, 2007): a region of a plane
// (a rectangle or a disk, centred on the origin of 2-D coordinates on that plane) onto
// which a receiver projects the occluders' contour, and the analytic integral of the
// area that a contour edge hides (radial integration around the light's centre, as the
// penumbra wedges of Assarsson and Akenine-Möller 2003 do).
//
// The identity used: for a contour oriented with the occluded side on its left, the
// edges' "beyond" areas (the part of the light inside the edge's angular sector seen
// from the centre, beyond the edge) sum, with the sign of each edge's turn around the
// centre, to (winding of the contour around the centre) |L| - |occluded ∩ L|. The
// winding is 1 exactly where the centre itself is occluded, the hard shadow's answer
// at the centre of the map's view, so
//     occluded area = [centre occluded] |L| - sum over edges of beyond(edge),
// edges clipped to the light first: a piece outside the light hides nothing of it, and
// the light's own border adds nothing (its sector and triangle areas are equal).
#ifndef PENUMBRA_BACKPROJECTION_LIGHT_AREA_GLSL
#define PENUMBRA_BACKPROJECTION_LIGHT_AREA_GLSL
// Its loops are [[unroll]]ed (the including shader enables GL_EXT_control_flow_attributes):
// llvmpipe counts every loop iteration of an invocation against one limit (contour.glsl),
// and a packet integrates an edge for each of up to 16 receivers.

float lightCross(vec2 a, vec2 b) { return a.x * b.y - a.y * b.x; }

// One side of clipToRect: the segment's parameter t on a + t d meets the side's line
// where p t = q (p: the side's outward component of d); false when the segment runs
// parallel to the side outside it.
bool clipToSide(float p, float q, inout float t0, inout float t1)
{
    if (p == 0.0) return q >= 0.0;
    float t = q / p;
    if (p < 0.0) t0 = max(t0, t);
    else t1 = min(t1, t);
    return true;
}

// Clips the segment a -> b to the rectangle |x| <= h.x, |y| <= h.y (Liang-Barsky);
// false when nothing is left. The four sides without a loop: a loop that leaves early is
// not unrolled, and each of its iterations would count against llvmpipe's loop limit
// (contour.glsl) once per edge and receiver.
bool clipToRect(inout vec2 a, inout vec2 b, vec2 h)
{
    vec2 d = b - a;
    float t0 = 0.0, t1 = 1.0;
    bool inside = clipToSide(-d.x, a.x + h.x, t0, t1) && clipToSide(d.x, h.x - a.x, t0, t1) &&
                  clipToSide(-d.y, a.y + h.y, t0, t1) && clipToSide(d.y, h.y - a.y, t0, t1);
    if (!inside || !(t0 < t1)) return false;
    vec2 a0 = a;
    a = a0 + t0 * d;
    b = a0 + t1 * d;
    return true;
}

// Clips the segment a -> b to the disk |x| <= r; false when nothing is left.
bool clipToDisk(inout vec2 a, inout vec2 b, float r)
{
    vec2 d = b - a;
    float dd = dot(d, d);
    if (!(dd > 0.0)) return false;
    // |a + t d|^2 = r^2: t = (-a.d +- sqrt((a.d)^2 - dd (a.a - r^2))) / dd, with the
    // discriminant as dd r^2 - cross(a, d)^2 (no cancellation for a far outside).
    float ad = dot(a, d);
    float c = lightCross(a, d);
    float disc = dd * r * r - c * c;
    if (!(disc > 0.0)) return false;
    float s = sqrt(disc);
    float t0 = max((-ad - s) / dd, 0.0), t1 = min((-ad + s) / dd, 1.0);
    if (!(t0 < t1)) return false;
    vec2 a0 = a;
    a = a0 + t0 * d;
    b = a0 + t1 * d;
    return true;
}

// Where the ray from the centre along d (not zero) leaves the rectangle.
vec2 rectExit(vec2 d, vec2 h)
{
    vec2 ad = abs(d);
    float sx = ad.x > 0.0 ? h.x / ad.x : 3.4e38, sy = ad.y > 0.0 ? h.y / ad.y : 3.4e38;
    return d * min(sx, sy);
}

// The area of the rectangle inside the sector from direction a to direction b turning
// counter-clockwise by less than pi (cross(a, b) >= 0): a fan from the centre through
// the exit points and the corners between them.
float rectSectorCcw(vec2 a, vec2 b, vec2 h)
{
    vec2 corner[4] = vec2[4](vec2(h.x, h.y), vec2(-h.x, h.y), vec2(-h.x, -h.y), vec2(h.x, -h.y));
    bool inside[4];
    [[unroll]] for (int k = 0; k < 4; ++k) inside[k] = lightCross(a, corner[k]) > 0.0 && lightCross(corner[k], b) > 0.0;
    // At most two corners lie in a sector narrower than pi, and they are neighbours:
    // in counter-clockwise order they are k, k + 1, except that 3 comes before 0.
    vec2 previous = rectExit(a, h);
    float twice = 0.0;
    bool wraps = inside[3] && inside[0];
    [[unroll]] for (int i = 0; i < 4; ++i) {
        int k = wraps ? (i + 3) % 4 : i;
        if (!inside[k]) continue;
        twice += lightCross(previous, corner[k]);
        previous = corner[k];
    }
    twice += lightCross(previous, rectExit(b, h));
    return 0.5 * twice;
}

// beyond(a, b) for the clipped edge a -> b inside the light: the light's area in the
// edge's sector minus the triangle (centre, a, b), signed by the edge's turn around the
// centre (positive counter-clockwise). Zero for an edge through the centre.
float beyondRect(vec2 a, vec2 b, vec2 h)
{
    float turn = lightCross(a, b);
    if (turn == 0.0) return 0.0;
    float sector = turn > 0.0 ? rectSectorCcw(a, b, h) : -rectSectorCcw(b, a, h);
    return sector - 0.5 * turn;
}

float beyondDisk(vec2 a, vec2 b, float r)
{
    float turn = lightCross(a, b);
    if (turn == 0.0) return 0.0;
    return 0.5 * r * r * atan(turn, dot(a, b)) - 0.5 * turn;
}

// beyond() of the segment a -> b after clipping it to the light: h = (half width, half
// height) of a rectangle, or (radius, 0) of a disk.
float edgeBeyond(vec2 a, vec2 b, vec2 h, bool disk)
{
    if (disk) return clipToDisk(a, b, h.x) ? beyondDisk(a, b, h.x) : 0.0;
    return clipToRect(a, b, h) ? beyondRect(a, b, h) : 0.0;
}

#endif
