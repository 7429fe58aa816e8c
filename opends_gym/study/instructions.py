"""The instruction page a person reads before each block of a study.

Why a page of its own and not the drive window's hold: it comes before the block's env
exists (the block's condition is told first), and it must be able to end the session
(Escape) without a drive started. Scripted and headless sessions auto-advance: the text goes
to the log and stdout, so the session's transcript still shows what the person was told.
"""

from __future__ import annotations

import logging
import textwrap
import time

log = logging.getLogger(__name__)
CONTINUE_KEYS = ("K_RETURN", "K_SPACE", "K_KP_ENTER")


def show_instructions(title: str, text: str, *, window: bool, auto_advance: bool, size: tuple[int, int] = (1280, 720)) -> bool:
    """Show the page until Return/Space (or a joystick button); False when the person quits (Escape, close)."""
    log.info("instructions: %s: %s", title, text)
    if auto_advance or not window:
        print(f"== {title}\n{text}", flush=True)
        return True
    import pygame

    pygame.init()
    screen = pygame.display.set_mode(size)
    pygame.display.set_caption(f"opends-gym study: {title}")
    font = pygame.font.SysFont(None, 40)
    big = pygame.font.SysFont(None, 56)
    lines = [*textwrap.wrap(text, 60), "", "Press Return to start, Escape to stop the session."]
    try:
        while True:
            screen.fill((20, 20, 30))
            screen.blit(big.render(title, True, (255, 255, 255)), (60, 60))
            for k, line in enumerate(lines):
                screen.blit(font.render(line, True, (230, 230, 230)), (60, 150 + 44 * k))
            pygame.display.flip()
            for ev in pygame.event.get():
                if ev.type == pygame.QUIT:
                    return False
                if ev.type == pygame.KEYDOWN:
                    if ev.key == pygame.K_ESCAPE:
                        return False
                    if any(ev.key == getattr(pygame, name) for name in CONTINUE_KEYS):
                        return True
                if ev.type == getattr(pygame, "JOYBUTTONDOWN", -1):
                    return True
            time.sleep(1 / 30)
    finally:
        pygame.display.quit()
