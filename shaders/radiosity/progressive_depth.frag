#version 450
// The depth pass writes only the depth of progressive_depth.vert (Algorithm 1's linear depth).
void main() {}
