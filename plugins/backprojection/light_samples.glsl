// The light as a set of samples (Schwarz and Stamminger 2007, "Bitmask soft shadows"):
// which parts of the light a contour hides, as bits, so that the hidden parts of two
// depth layers unite (visibility.comp's LAYERS; the radial integration of light_area.glsl
// gives each layer's hidden area exactly but cannot tell how much two of them overlap).
//
// 16 rows of 16 samples over the light's bounding rectangle (a disk's square), two rows a
// word. Row r's samples sit at y = (r + 1/2) / 16 of the height and are sheared along x
// by (r + 1/2) / 16 of a column, so that an edge across the rows moves one sample at a
// time (256 steps) rather than a whole column (16).
//
// The same identity as light_area.glsl's, sample by sample: a sample s is hidden when the
// winding of the layer's contour around it is odd, and that is the winding around the
// light's centre (centreOccluded) plus one for every edge that the segment from the
// centre to s crosses, i.e. every edge whose "beyond" region (inside the edge's sector
// seen from the centre, past the edge) holds s. So a layer's samples start as the
// centre's status and each edge flips the samples beyond it. Only what lies inside the
// light counts, so edges are clipped to it first, and a contour's open ends outside the
// light (where the kernel stops) change nothing.
#ifndef PENUMBRA_BACKPROJECTION_LIGHT_SAMPLES_GLSL
#define PENUMBRA_BACKPROJECTION_LIGHT_SAMPLES_GLSL

#define LIGHT_SAMPLE_ROWS 16
#define LIGHT_SAMPLE_WORDS 8  // 16 rows of 16 bits
const uint kLightSamplesAll = 0xffffffffu;

struct LightSamples {
    uint bits[LIGHT_SAMPLE_WORDS];
};

LightSamples lightSamplesFilled(bool hidden)
{
    LightSamples s;
    [[unroll]] for (int i = 0; i < LIGHT_SAMPLE_WORDS; ++i) s.bits[i] = hidden ? kLightSamplesAll : 0u;
    return s;
}

// The bits of row r whose samples lie in [lo, hi] along x (h: the rectangle's half
// sizes): columns c with lo <= -h.x + (c + shear) 2 h.x / 16 <= hi. Clamped before the
// conversion to int (no overflow, no NaN: the constant first).
uint lightSampleSpan(int r, float lo, float hi, vec2 h)
{
    float column = 2.0 * h.x / float(LIGHT_SAMPLE_ROWS);
    float shear = (float(r) + 0.5) / float(LIGHT_SAMPLE_ROWS);
    float first = clamp(ceil((lo + h.x) / column - shear), 0.0, 16.0);
    float last = clamp(floor((hi + h.x) / column - shear), -1.0, 15.0);
    if (!(first <= last)) return 0u;
    uint upTo = (2u << uint(last)) - 1u;  // bits 0 .. last (last <= 15: no overflow)
    return upTo & ~((1u << uint(first)) - 1u);
}

float lightSampleRowY(int r, vec2 h)
{
    return -h.y + (float(r) + 0.5) * (2.0 * h.y / float(LIGHT_SAMPLE_ROWS));
}

// The interval of x where A x <= B holds, intersected into [lo, hi].
void lightSampleBound(float a, float b, inout float lo, inout float hi)
{
    if (a > 0.0) hi = min(hi, b / a);
    else if (a < 0.0) lo = max(lo, b / a);
    else if (b < 0.0) lo = 3.4e38;  // holds nowhere
}

// Flips the samples beyond the edge a -> b (light-plane coordinates, either orientation:
// parity does not depend on it), clipped to the rectangle h first.
void lightSamplesFlipBeyond(inout LightSamples s, vec2 a, vec2 b, vec2 h)
{
    if (!clipToRect(a, b, h)) return;
    float turn = lightCross(a, b);
    if (turn == 0.0) return;  // through the centre: no segment from it crosses the edge
    if (turn < 0.0) {
        vec2 t = a;
        a = b;
        b = t;
    }
    vec2 d = b - a;
    float beyond = -d.y * a.x + d.x * a.y;  // cross(d, s - a) <= 0 as -d.y x <= beyond - d.x y
    [[unroll]] for (int r = 0; r < LIGHT_SAMPLE_ROWS; ++r) {
        float y = lightSampleRowY(r, h);
        float lo = -3.4e38, hi = 3.4e38;
        lightSampleBound(a.y, a.x * y, lo, hi);    // left of the ray through a: cross(a, s) >= 0
        lightSampleBound(-b.y, -b.x * y, lo, hi);  // right of the ray through b: cross(s, b) >= 0
        lightSampleBound(-d.y, beyond - d.x * y, lo, hi);
        s.bits[r >> 1] ^= lightSampleSpan(r, lo, hi, h) << (16 * (r & 1));
    }
}

// The samples that lie on the light: all of a rectangle's, a disk's inside its radius.
LightSamples lightSamplesOn(vec2 h, bool disk)
{
    LightSamples s = lightSamplesFilled(!disk);
    if (!disk) return s;
    [[unroll]] for (int r = 0; r < LIGHT_SAMPLE_ROWS; ++r) {
        float y = lightSampleRowY(r, h);
        float chord = sqrt(max(h.x * h.x - y * y, 0.0));
        s.bits[r >> 1] |= lightSampleSpan(r, -chord, chord, h) << (16 * (r & 1));
    }
    return s;
}

// The samples of a and of b and of on.
uint lightSamplesCountBoth(LightSamples a, LightSamples b, LightSamples on)
{
    uint n = 0u;
    [[unroll]] for (int i = 0; i < LIGHT_SAMPLE_WORDS; ++i) n += uint(bitCount(a.bits[i] & b.bits[i] & on.bits[i]));
    return n;
}

#endif
