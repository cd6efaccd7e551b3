// OpenGL 3.3 core entry points, linked directly from libGL (libglvnd exports every core function).
#pragma once
#ifndef GL_GLEXT_PROTOTYPES
#define GL_GLEXT_PROTOTYPES 1
#endif
#include <GL/glcorearb.h>
