#version 460
// Start-up calibration of the tile cost (adaptive_sm.cpp calibrateTileCost): one triangle
// over the whole viewport at mid depth, so that every texel of the tile is drawn once.
void main()
{
    vec2 p = vec2((gl_VertexIndex << 1) & 2, gl_VertexIndex & 2);
    gl_Position = vec4(p * 2.0 - 1.0, 0.5, 1.0);
}
