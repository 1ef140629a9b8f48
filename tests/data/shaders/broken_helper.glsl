// A helper with a type error on line 4.
float helper(float x)
{
    return vec3(x);
}
