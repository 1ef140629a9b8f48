#version 460
#include "broken_helper.glsl"
layout(local_size_x = 1) in;
void main() { float y = helper(1.0); }
