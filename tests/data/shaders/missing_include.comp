#version 460
#include "does_not_exist.glsl"
layout(local_size_x = 1) in;
void main() {}
