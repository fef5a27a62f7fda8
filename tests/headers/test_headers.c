/* Links the per-header translation units; compiling them is the test. */
#include <stdio.h>

int main(void)
{
    puts("every public header compiles alone as C and C++");
    return 0;
}
