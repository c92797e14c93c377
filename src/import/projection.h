/* A finite projective camera P = K [R | t] (3x4, world -> homogeneous pixels, OpenCV's camera
 * frame: +X right, +Y down, looking along +Z) split back into its intrinsics K, rotation R and
 * centre C, the job of OpenCV's decomposeProjectionMatrix (an RQ decomposition of P's left 3x3
 * M = K R), which NeuS and IDR use to read DTU's cameras. */
#ifndef ESR_IO_PROJECTION_H
#define ESR_IO_PROJECTION_H

struct esr_projection_parts {
    double k[3][3];      /* upper triangular, k[2][2] = 1, fx = k[0][0] > 0, fy = k[1][1] > 0,
                            skew k[0][1], principal point (k[0][2], k[1][2]) */
    double r[3][3];      /* world -> camera rotation, det +1 */
    double centre[3];    /* camera centre in the world: P (C, 1) = 0 */
};

/* Splits p. A projection matrix is defined up to scale, sign included: when det M < 0 (P
 * multiplied by a negative number, as a homogeneous matrix may be) the decomposition is that of
 * -P, which projects every point to the same pixel. OpenCV keeps the sign instead and returns
 * K[2][2] < 0 with R turned half a turn about the optical axis; normalising its K by K[2][2], as
 * NeuS does, then gives negative focal lengths that describe the same rays. Here fx, fy > 0 and
 * points in front of the camera (depth > 0) are those P sees (Hartley & Zisserman 6.2.3). Fails
 * when M is singular or not finite (`what` names the camera in the message). */
int esr_projection_decompose(const double p[3][4], const char *what, struct esr_projection_parts *out);

#endif
